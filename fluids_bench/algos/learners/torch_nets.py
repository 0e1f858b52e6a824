"""PyTorch learners: `MLPLearner` for vector observations, `CNNLearner` for images.

Both implement the [learner protocol][fluids_bench.algos.learners.protocol] and need the
optional `torch` extra (`pip install torch==2.13.0`, the CPU wheel; or
`pip install "fluids-bench[torch]"`); torch is imported only when a learner is built.

- Task: a Discrete action space (from `set_spaces`, which the algorithms call, or integer labels
  when used alone) gives a classifier (cross-entropy, arg-max); a Box one a regressor (squared
  error), its predictions clipped to the bounds.
- Inputs: `MLPLearner` flattens and standardises every feature with the mean and standard
  deviation of the data of each fit; `CNNLearner` takes `(n, H, W, C)` or `(n, H, W)` images,
  divides uint8 pixels by 255 and runs three convolutions (the DQN stack, the last one padded),
  an adaptive average pool to 4x4 and `hidden` fully connected layers, so any image of at least
  36 px works (FLUIDS' bird's-eye 64–512 px, the grasping, singulation and track pixels).
- Determinism: the weights are initialised from `seed` (under a forked torch RNG: the global one
  is untouched) and each fit shuffles and splits with a numpy generator seeded by
  `(seed, fit number)`. On a CPU the same data gives the same weights bit for bit (same machine
  and torch build); a GPU (`device="auto"` uses one when present, never required) need not.
- Warm start (`warm_start=True`, the default): each fit continues from the previous weights with a
  fresh Adam, so DAgger's iterations refine one network instead of training a new one.
- Threads: `threads=N` sets torch's intra-op threads for each fit and predict (and restores
  them); small networks train fastest on 1 thread, and a loaded machine punishes more.
- Early stopping: `validation_fraction` of the pairs (when there are at least 20) are held out;
  training stops after `patience` epochs without a lower validation loss and the best weights are
  kept. `history` lists every fit's epochs and losses; `progress=True` prints a line per epoch to
  stderr (or pass a callable that receives each epoch's dict).
- Checkpoints: `save(path)` writes one `.npz` holding the weights, the input statistics and a
  JSON config (`config.json`, as UTF-8 bytes, with `history`); [`load_learner`][fluids_bench.algos.learners.torch_nets.load_learner]
  reads it back with `allow_pickle=False` and rebuilds the network: nothing is unpickled and
  `torch.load` is never called. The reloaded learner predicts the same actions.
"""

from __future__ import annotations

import io
import json
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from fluids_bench.core.validation import check_bool, check_float, check_int, fail

FORMAT = "fluids-bench-learner"
FORMAT_VERSION = 1
INSTALL = 'pip install torch==2.13.0  (the CPU wheel; or pip install "fluids-bench[torch]")'
MIN_VALIDATION_PAIRS = 20  # below this many pairs a fit trains on all of them, for `epochs`
PREDICT_BATCH = 1024
MIN_IMAGE_SIZE = 36  # the two strided convolutions need this many pixels


def import_torch() -> Any:
    """The `torch` module, or an ImportError naming the `torch` extra."""
    try:
        import torch
    except ImportError as exc:
        raise ImportError(
            f"the torch learners (MLPLearner, CNNLearner) need the optional `torch` extra: "
            f"{INSTALL}"
        ) from exc
    return torch


class TorchLearner:
    """Shared training loop of the torch learners (see the module's docstring)."""

    kind = ""

    def __init__(
        self,
        *,
        hidden: Sequence[int] = (256, 256),
        epochs: int = 100,
        batch_size: int = 64,
        learning_rate: float = 1e-3,
        weight_decay: float = 0.0,
        validation_fraction: float = 0.1,
        patience: int = 10,
        warm_start: bool = True,
        seed: int = 0,
        device: str = "cpu",
        threads: int | None = None,
        progress: bool | Callable[[dict[str, Any]], None] = False,
    ) -> None:
        where = type(self).__name__
        if isinstance(hidden, str | bytes) or not isinstance(hidden, Sequence):
            fail(where, "hidden", hidden, "a list of layer widths >= 1")
        self.hidden = tuple(check_int(where, "hidden", h, 1) for h in hidden)
        self.epochs = check_int(where, "epochs", epochs, 1)
        self.batch_size = check_int(where, "batch_size", batch_size, 1)
        self.learning_rate = check_float(where, "learning_rate", learning_rate, 0.0, lo_open=True)
        self.weight_decay = check_float(where, "weight_decay", weight_decay, 0.0)
        self.validation_fraction = check_float(
            where, "validation_fraction", validation_fraction, 0.0, 1.0, hi_open=True
        )
        self.patience = check_int(where, "patience", patience, 1)
        self.warm_start = check_bool(where, "warm_start", warm_start)
        self.seed = check_int(where, "seed", seed, 0, 2**32 - 1)
        if not isinstance(device, str) or not (
            device in ("cpu", "auto") or device.startswith("cuda")
        ):
            fail(where, "device", device, "'cpu', 'auto' (a GPU when present) or 'cuda[:N]'")
        self.device = device
        self.threads = None if threads is None else check_int(where, "threads", threads, 1)
        if not (isinstance(progress, bool) or callable(progress)):
            fail(where, "progress", progress, "true, false or a callable taking a dict")
        self.progress = progress
        import_torch()  # fail now, naming the extra, not at the first fit
        # set by set_spaces or the first fit
        self.observation_shape: tuple[int, ...] | None = None
        self.discrete: bool | None = None
        self.n_outputs = 0
        self.action_shape: tuple[int, ...] = ()
        self.action_start = 0
        self.low: np.ndarray | None = None
        self.high: np.ndarray | None = None
        self.input_mean: np.ndarray | None = None
        self.input_scale: np.ndarray | None = None
        self.fits = 0
        self.history: list[dict[str, Any]] = []
        self._model: Any = None

    # -- what the subclasses define ------------------------------------------------------------

    def _check_observation_shape(self, shape: tuple[int, ...]) -> None:
        raise NotImplementedError

    def _build(self, torch: Any) -> Any:
        raise NotImplementedError

    def _prepare(self, observations: np.ndarray, fitting: bool) -> np.ndarray:
        """Observations as the float32 array the network reads (fitting: statistics updated)."""
        raise NotImplementedError

    # -- configuration -------------------------------------------------------------------------

    def params(self) -> dict[str, Any]:
        """The constructor's keyword arguments (JSON-friendly; a progress callable is left out)."""
        return {
            "hidden": list(self.hidden),
            "epochs": self.epochs,
            "batch_size": self.batch_size,
            "learning_rate": self.learning_rate,
            "weight_decay": self.weight_decay,
            "validation_fraction": self.validation_fraction,
            "patience": self.patience,
            "warm_start": self.warm_start,
            "seed": self.seed,
            "device": self.device,
            "threads": self.threads,
        }

    def describe(self) -> str:
        """How records name this learner: its kind and parameters."""
        return f"torch-{self.kind} {json.dumps(self.params(), sort_keys=True)}"

    def set_spaces(
        self, observation_space: spaces.Space[Any], action_space: spaces.Space[Any]
    ) -> None:
        """Size the network for the env's spaces (the algorithms call this before fitting)."""
        where = type(self).__name__
        if not isinstance(observation_space, spaces.Box):
            fail(where, "observation_space", observation_space, "a Box observation space")
        if isinstance(action_space, spaces.Discrete):
            target = (True, int(action_space.n), (), int(action_space.start), None, None)
        elif isinstance(action_space, spaces.Box):
            shape = tuple(action_space.shape)
            low = np.asarray(action_space.low, dtype=np.float64).reshape(-1)
            high = np.asarray(action_space.high, dtype=np.float64).reshape(-1)
            target = (False, int(np.prod(shape)), shape, 0, low, high)
        else:
            fail(where, "action_space", action_space, "a Discrete or Box action space")
        self._set_shapes(tuple(observation_space.shape), *target)

    def _set_shapes(
        self,
        observation_shape: tuple[int, ...],
        discrete: bool,
        n_outputs: int,
        action_shape: tuple[int, ...],
        action_start: int,
        low: np.ndarray | None,
        high: np.ndarray | None,
    ) -> None:
        if self._model is not None:
            known = (self.observation_shape, self.discrete, self.n_outputs)
            if known != (observation_shape, discrete, n_outputs):
                raise ValueError(
                    f"{type(self).__name__}: the network was built for observations "
                    f"{self.observation_shape} and {self.n_outputs} outputs; these spaces need "
                    f"{observation_shape} and {n_outputs}: build a new learner"
                )
            return
        self._check_observation_shape(observation_shape)
        self.observation_shape = observation_shape
        self.discrete, self.n_outputs = discrete, n_outputs
        self.action_shape, self.action_start = action_shape, action_start
        self.low, self.high = low, high

    def _infer_shapes(self, observations: np.ndarray, labels: np.ndarray) -> None:
        """Without `set_spaces`: integer labels are classes `0..max`, others a Box."""
        if np.issubdtype(labels.dtype, np.integer):
            if labels.min() < 0:
                raise ValueError(
                    f"{type(self).__name__}.fit: integer labels from {labels.min()}; allowed: "
                    "classes >= 0 (or call set_spaces with the Discrete action space)"
                )
            n = int(labels.max()) + 1
            self._set_shapes(tuple(observations.shape[1:]), True, n, (), 0, None, None)
        else:
            shape = tuple(labels.shape[1:])
            n = int(np.prod(shape))
            self._set_shapes(tuple(observations.shape[1:]), False, n, shape, 0, None, None)

    # -- fitting -------------------------------------------------------------------------------

    def _torch_device(self, torch: Any) -> Any:
        if self.device == "auto":
            return torch.device("cuda" if torch.cuda.is_available() else "cpu")
        return torch.device(self.device)

    def _new_model(self, torch: Any) -> Any:
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(self.seed)
            model = self._build(torch)
        return model.to(self._torch_device(torch))

    def _targets(self, torch: Any, labels: np.ndarray, n: int) -> Any:
        if self.discrete:
            codes = np.asarray(labels).reshape(n).astype(np.int64) - self.action_start
            if codes.min() < 0 or codes.max() >= self.n_outputs:
                raise ValueError(
                    f"{type(self).__name__}.fit: labels outside the {self.n_outputs} classes "
                    f"from {self.action_start}"
                )
            return torch.from_numpy(codes)
        return torch.from_numpy(np.asarray(labels, dtype=np.float32).reshape(n, self.n_outputs))

    def fit(self, observations: np.ndarray, labels: np.ndarray) -> TorchLearner:
        """Train on the pairs (from the previous weights when `warm_start`); returns self."""
        with self._threads():
            return self._fit(np.asarray(observations), np.asarray(labels))

    @contextmanager
    def _threads(self) -> Iterator[None]:
        """torch's intra-op threads set to `threads` for the call (None: left as they are)."""
        torch = import_torch()
        if self.threads is None:
            yield
            return
        before = torch.get_num_threads()
        torch.set_num_threads(self.threads)
        try:
            yield
        finally:
            torch.set_num_threads(before)

    def _fit(self, observations: np.ndarray, labels: np.ndarray) -> TorchLearner:
        torch = import_torch()
        observations, labels = np.asarray(observations), np.asarray(labels)
        n = len(observations)
        if n == 0 or len(labels) != n:
            raise ValueError(
                f"{type(self).__name__}.fit: {n} observations and {len(labels)} labels; "
                "allowed: the same number, at least one"
            )
        if self.observation_shape is None:
            self._infer_shapes(observations, labels)
        if tuple(observations.shape[1:]) != self.observation_shape:
            raise ValueError(
                f"{type(self).__name__}.fit: observations of shape {observations.shape[1:]}; "
                f"allowed: {self.observation_shape}"
            )
        device = self._torch_device(torch)
        X = torch.from_numpy(self._prepare(observations, fitting=True)).to(device)
        y = self._targets(torch, labels, n).to(device)
        if self._model is None or not self.warm_start:
            self._model = self._new_model(torch)
        model = self._model
        rng = np.random.default_rng([self.seed, self.fits])
        self.fits += 1
        order = rng.permutation(n)
        n_val = int(round(self.validation_fraction * n)) if n >= MIN_VALIDATION_PAIRS else 0
        val, train = order[:n_val], order[n_val:]
        optimizer = torch.optim.Adam(
            model.parameters(), lr=self.learning_rate, weight_decay=self.weight_decay
        )
        loss_fn = torch.nn.functional.cross_entropy if self.discrete else _mse(torch)
        best, best_epoch, best_state = np.inf, 0, None
        epochs: list[dict[str, Any]] = []
        for epoch in range(1, self.epochs + 1):
            model.train()
            total = 0.0
            shuffled = train[rng.permutation(len(train))]
            for start in range(0, len(shuffled), self.batch_size):
                batch = torch.from_numpy(shuffled[start : start + self.batch_size]).to(device)
                loss = loss_fn(model(X[batch]), y[batch])
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
                total += float(loss.detach()) * len(batch)
            entry: dict[str, Any] = {
                "fit": self.fits,
                "epoch": epoch,
                "epochs": self.epochs,
                "train_loss": total / len(train),
                "val_loss": None,
            }
            stop = False
            if n_val:
                model.eval()
                with torch.inference_mode():
                    idx = torch.from_numpy(val).to(device)
                    val_loss = float(loss_fn(model(X[idx]), y[idx]))
                entry["val_loss"] = val_loss
                if val_loss < best:
                    best, best_epoch = val_loss, epoch
                    best_state = {k: v.detach().clone() for k, v in model.state_dict().items()}
                stop = epoch - best_epoch >= self.patience
            epochs.append(entry)
            self._report(entry)
            if stop:
                break
        if best_state is not None:
            model.load_state_dict(best_state)
        self.history.append(
            {
                "fit": self.fits,
                "pairs": n,
                "validation_pairs": n_val,
                "epochs_run": len(epochs),
                "best_epoch": best_epoch if n_val else len(epochs),
                "best_val_loss": None if not n_val else best,
                "train_loss": epochs[-1]["train_loss"],
            }
        )
        return self

    def _report(self, entry: dict[str, Any]) -> None:
        if callable(self.progress):
            self.progress(entry)
        elif self.progress:
            val = "" if entry["val_loss"] is None else f", validation {entry['val_loss']:.4g}"
            print(
                f"{self.kind} fit {entry['fit']}: epoch {entry['epoch']}/{entry['epochs']}, "
                f"train loss {entry['train_loss']:.4g}{val}",
                file=sys.stderr,
                flush=True,
            )

    # -- predicting ----------------------------------------------------------------------------

    def predict(self, observations: np.ndarray) -> np.ndarray:
        """Actions for a batch: int64 `(n,)` (Discrete) or `(n, *action_shape)` (Box)."""
        with self._threads():
            return self._predict(np.asarray(observations))

    def _predict(self, observations: np.ndarray) -> np.ndarray:
        torch = import_torch()
        if self._model is None:
            raise ValueError(f"{type(self).__name__}.predict: call fit (or load_learner) first")
        observations = np.asarray(observations)
        if tuple(observations.shape[1:]) != self.observation_shape:
            raise ValueError(
                f"{type(self).__name__}.predict: observations of shape "
                f"{observations.shape[1:]}; allowed: {self.observation_shape}"
            )
        device = self._torch_device(torch)
        X = self._prepare(observations, fitting=False)
        self._model.eval()
        outputs = []
        with torch.inference_mode():
            for start in range(0, len(X), PREDICT_BATCH):
                batch = torch.from_numpy(X[start : start + PREDICT_BATCH]).to(device)
                outputs.append(self._model(batch).cpu().numpy())
        out = np.concatenate(outputs) if outputs else np.empty((0, self.n_outputs), np.float32)
        if self.discrete:
            return np.argmax(out, axis=1).astype(np.int64) + self.action_start
        out = out.astype(np.float64)
        if self.low is not None and self.high is not None:
            out = np.clip(out, self.low, self.high)
        return out.reshape((len(out), *self.action_shape))

    # -- checkpoints ---------------------------------------------------------------------------

    def save(self, path: str | Path) -> Path:
        """Write the learner to `path` (a `.npz`; atomic): weights, input statistics, config."""
        from fluids_bench.algos.results import write_bytes_atomic

        if self._model is None:
            raise ValueError(f"{type(self).__name__}.save: nothing to save before the first fit")
        config = {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "kind": self.kind,
            "params": self.params(),
            "observation_shape": list(self.observation_shape or ()),
            "discrete": self.discrete,
            "n_outputs": self.n_outputs,
            "action_shape": list(self.action_shape),
            "action_start": self.action_start,
            "fits": self.fits,
            "history": self.history,  # every fit's epochs and losses (plain numbers)
        }
        arrays: dict[str, np.ndarray] = {
            "config.json": np.frombuffer(json.dumps(config).encode(), dtype=np.uint8)
        }
        for name, tensor in self._model.state_dict().items():
            arrays[f"weights/{name}"] = tensor.detach().cpu().numpy()
        for name in ("low", "high", "input_mean", "input_scale"):
            value = getattr(self, name)
            if value is not None:
                arrays[name] = np.asarray(value)
        buffer = io.BytesIO()
        np.savez(buffer, **arrays)
        path = Path(path)
        write_bytes_atomic(path, buffer.getvalue())
        return path

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        if callable(state["progress"]):  # a callback stays in the process that set it
            state["progress"] = False
        return state


def _mse(torch: Any) -> Callable[[Any, Any], Any]:
    return torch.nn.functional.mse_loss


class MLPLearner(TorchLearner):
    """A multi-layer perceptron (ReLU) on flattened, standardised observations."""

    kind = "mlp"

    def _check_observation_shape(self, shape: tuple[int, ...]) -> None:
        if not shape:
            fail(type(self).__name__, "observation_shape", shape, "at least one dimension")

    def _build(self, torch: Any) -> Any:
        layers: list[Any] = []
        width = int(np.prod(self.observation_shape))
        for h in self.hidden:
            layers += [torch.nn.Linear(width, h), torch.nn.ReLU()]
            width = h
        layers.append(torch.nn.Linear(width, self.n_outputs))
        return torch.nn.Sequential(*layers)

    def _prepare(self, observations: np.ndarray, fitting: bool) -> np.ndarray:
        X = np.asarray(observations, dtype=np.float64).reshape(len(observations), -1)
        if fitting:
            std = X.std(axis=0)
            self.input_mean = X.mean(axis=0)
            self.input_scale = np.where(std > 1e-8, std, 1.0)
        assert self.input_mean is not None and self.input_scale is not None
        return ((X - self.input_mean) / self.input_scale).astype(np.float32)


class CNNLearner(TorchLearner):
    """A small convolutional network on images `(H, W, C)` or `(H, W)` (see the module)."""

    kind = "cnn"

    def __init__(self, *, hidden: Sequence[int] = (256,), **kwargs: Any) -> None:
        super().__init__(hidden=hidden, **kwargs)

    def _check_observation_shape(self, shape: tuple[int, ...]) -> None:
        ok = len(shape) == 2 or (len(shape) == 3 and 1 <= shape[2] <= 4)
        if not ok or min(shape[:2]) < MIN_IMAGE_SIZE:
            fail(
                type(self).__name__,
                "observation_shape",
                shape,
                f"an image (H, W) or (H, W, C) with C <= 4 and H, W >= {MIN_IMAGE_SIZE} "
                "(MLPLearner takes vectors)",
            )

    def _build(self, torch: Any) -> Any:
        nn = torch.nn
        assert self.observation_shape is not None
        channels = 1 if len(self.observation_shape) == 2 else self.observation_shape[2]
        layers: list[Any] = [
            nn.Conv2d(channels, 32, 8, stride=4),
            nn.ReLU(),
            nn.Conv2d(32, 64, 4, stride=2),
            nn.ReLU(),
            nn.Conv2d(64, 64, 3, stride=1, padding=1),
            nn.ReLU(),
            nn.AdaptiveAvgPool2d((4, 4)),
            nn.Flatten(),
        ]
        width = 64 * 4 * 4
        for h in self.hidden:
            layers += [nn.Linear(width, h), nn.ReLU()]
            width = h
        layers.append(nn.Linear(width, self.n_outputs))
        return nn.Sequential(*layers)

    def _prepare(self, observations: np.ndarray, fitting: bool) -> np.ndarray:
        images = np.asarray(observations)
        scale = 255.0 if images.dtype == np.uint8 else 1.0
        X = images.astype(np.float32) / np.float32(scale)
        if X.ndim == 3:
            X = X[:, None]
        else:
            X = np.ascontiguousarray(X.transpose(0, 3, 1, 2))
        return X


KINDS: dict[str, type[TorchLearner]] = {"mlp": MLPLearner, "cnn": CNNLearner}


def load_learner(path: str | Path) -> TorchLearner:
    """The learner `save` wrote to `path`, rebuilt from its arrays and JSON config (no pickle,
    no `torch.load`); it predicts what the saved learner predicted."""
    torch = import_torch()
    path = Path(path)
    try:
        archive = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise ValueError(f"load_learner: {path} is not a learner checkpoint (.npz): {exc}") from exc
    with archive:
        if "config.json" not in archive.files:
            raise ValueError(f"load_learner: {path} holds no config.json; not a learner checkpoint")
        config = json.loads(archive["config.json"].tobytes().decode())
        if config.get("format") != FORMAT or config.get("version") != FORMAT_VERSION:
            raise ValueError(
                f"load_learner: {path} is format {config.get('format')!r} version "
                f"{config.get('version')!r}; allowed: {FORMAT!r} version {FORMAT_VERSION}"
            )
        if config.get("kind") not in KINDS:
            raise ValueError(
                f"load_learner: {path} holds kind {config.get('kind')!r}; allowed: {sorted(KINDS)}"
            )
        learner = KINDS[config["kind"]](**config["params"])
        learner._set_shapes(  # noqa: SLF001
            tuple(config["observation_shape"]),
            bool(config["discrete"]),
            int(config["n_outputs"]),
            tuple(config["action_shape"]),
            int(config["action_start"]),
            archive["low"] if "low" in archive.files else None,
            archive["high"] if "high" in archive.files else None,
        )
        for name in ("input_mean", "input_scale"):
            if name in archive.files:
                setattr(learner, name, archive[name])
        learner.fits = int(config["fits"])
        learner.history = list(config.get("history", []))
        model = learner._new_model(torch)  # noqa: SLF001
        state = {
            name.removeprefix("weights/"): torch.from_numpy(archive[name].copy())
            for name in archive.files
            if name.startswith("weights/")
        }
        model.load_state_dict(state, strict=True)
        learner._model = model  # noqa: SLF001
    return learner
