"""A small feed-forward policy evaluated in numpy, loaded from a hash-checked `.npz` file.

The locomotion supervisors that are trained policies ship as weight files inside the package.
No deep-learning framework is needed at run time: the forward pass is a few matrix products.

File format (`numpy.savez`): `obs_mean` and `obs_std` (the observation normaliser the
policy was trained with), then `W0, b0, W1, b1, ...` (layer `i` maps its input `x` to
`W_i @ x + b_i`; hidden layers use tanh). The output layer is squashed by tanh and scaled to the
action bounds, so the policy is never a linear function of the observation.

Two evaluations of the same network: `policy(obs)` is the float64 numpy forward pass the
training script rolls out (so a recorded training run reproduces the shipped file bit for bit),
batched over leading axes; `policy.act32(obs)` is the supervisor's label, one observation at
a time, a compiled loop (numba, no fused multiply-add) with the result rounded to float32, the
envs' action dtype. The two differ only in float64 rounding (numpy's matrix product sums in
BLAS's order): after rounding to float32 they agree on essentially every state (tested), and
the label costs under a microsecond instead of the numpy pass's several numpy calls.
"""

from __future__ import annotations

import hashlib
import io
import math
import re
import zipfile
from pathlib import Path

import numpy as np
from numba import njit


def sha256_of(path: str | Path) -> str:
    """Hex sha256 of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


class MLPPolicy:
    """`a = low + (tanh(f(x)) + 1) / 2 * (high - low)`, `f` an MLP on the normalised observation."""

    def __init__(
        self,
        obs_mean: np.ndarray,
        obs_std: np.ndarray,
        weights: list[np.ndarray],
        biases: list[np.ndarray],
        action_low: np.ndarray,
        action_high: np.ndarray,
    ) -> None:
        if len(weights) != len(biases) or not weights:
            raise ValueError(
                f"MLPPolicy: {len(weights)} weight matrices and {len(biases)} bias vectors; "
                "allowed: equal, non-zero counts"
            )
        self.obs_mean = np.asarray(obs_mean, dtype=np.float64)
        self.obs_std = np.asarray(obs_std, dtype=np.float64)
        self.weights = [np.asarray(w, dtype=np.float64) for w in weights]
        self.biases = [np.asarray(b, dtype=np.float64) for b in biases]
        self.action_low = np.asarray(action_low, dtype=np.float64)
        self.action_high = np.asarray(action_high, dtype=np.float64)
        self._check_values()
        dim = self.obs_mean.shape[0]
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            if w.ndim != 2 or w.shape[1] != dim or b.shape != (w.shape[0],):
                raise ValueError(
                    f"MLPPolicy: layer {i} has W {w.shape}, b {b.shape} after an input of {dim}; "
                    "allowed: W (out, in) with in equal to the previous width, b (out,)"
                )
            dim = w.shape[0]
        # precomputed once: the label is computed every env step
        self._hidden = list(zip(self.weights[:-1], self.biases[:-1], strict=True))
        self._w_out, self._b_out = self.weights[-1], self.biases[-1]
        self._range = self.action_high - self.action_low
        # the compiled label's parameters, flat: mean, std, (W_i row-major, b_i)..., low, range
        flat = [self.obs_mean, self.obs_std]
        for w, b in zip(self.weights, self.biases, strict=True):
            flat += [w.ravel(), b]
        self._flat = np.ascontiguousarray(np.concatenate([*flat, self.action_low, self._range]))
        self._sizes = np.array([self.obs_mean.shape[0], *(w.shape[0] for w in self.weights)])
        if dim != self.action_low.shape[0]:
            raise ValueError(
                f"MLPPolicy: output width {dim}; allowed: the action dimension "
                f"{self.action_low.shape[0]}"
            )

    def _check_values(self) -> None:
        """Shapes of the normaliser and the bounds, finite numbers everywhere, `obs_std > 0`
        (it divides) and `action_low < action_high`: a ValueError naming the array."""
        if self.obs_mean.ndim != 1 or self.obs_std.shape != self.obs_mean.shape:
            raise ValueError(
                f"MLPPolicy: obs_mean {self.obs_mean.shape}, obs_std {self.obs_std.shape}; "
                "allowed: two vectors of the observation size"
            )
        if self.action_low.ndim != 1 or self.action_high.shape != self.action_low.shape:
            raise ValueError(
                f"MLPPolicy: action_low {self.action_low.shape}, action_high "
                f"{self.action_high.shape}; allowed: two vectors of the action size"
            )
        named = {"obs_mean": self.obs_mean, "obs_std": self.obs_std}
        named |= {f"W{i}": w for i, w in enumerate(self.weights)}
        named |= {f"b{i}": b for i, b in enumerate(self.biases)}
        named |= {"action_low": self.action_low, "action_high": self.action_high}
        for name, array in named.items():
            # obs_std may be +inf: that input is ignored (the shipped Humanoid file does this
            # for observation entries that never vary); its NaN and <= 0 are refused below
            if not np.isfinite(array).all() and name != "obs_std":
                raise ValueError(
                    f"MLPPolicy: {name} holds {int((~np.isfinite(array)).sum())} NaN or "
                    "infinite values; allowed: finite numbers"
                )
        if not (self.obs_std > 0).all():  # False for NaN too
            raise ValueError(
                f"MLPPolicy: obs_std has {int((~(self.obs_std > 0)).sum())} entries <= 0 or NaN "
                f"(min {np.nanmin(self.obs_std)}); allowed: positive, or inf for an ignored "
                "input (the observation is divided by it)"
            )
        if not (self.action_low < self.action_high).all():
            raise ValueError(
                "MLPPolicy: action_low is not below action_high everywhere; allowed: "
                "action_low < action_high"
            )

    @property
    def obs_dim(self) -> int:
        return int(self.obs_mean.shape[0])

    def preactivation(self, obs: np.ndarray) -> np.ndarray:
        """The output layer's value before the tanh squashing (batched over leading axes)."""
        x = (obs - self.obs_mean) / self.obs_std
        for w, b in self._hidden:
            x = np.tanh(x @ w.T + b)
        return x @ self._w_out.T + self._b_out

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The deterministic action for `obs` (shape `(obs_dim,)` or `(n, obs_dim)`)."""
        # the arithmetic (and so every bit of the result) is the training script's
        return self.action_low + (np.tanh(self.preactivation(obs)) + 1.0) * 0.5 * self._range

    def act32(self, obs: np.ndarray) -> np.ndarray:
        """The supervisor's label for one observation (obs_dim,): float32, compiled."""
        return _forward32(obs, self._flat, self._sizes)

    def to_bytes(self) -> bytes:
        """The `.npz` bytes of this policy (the shipped file format)."""
        arrays = {"obs_mean": self.obs_mean, "obs_std": self.obs_std}
        arrays["action_low"] = self.action_low
        arrays["action_high"] = self.action_high
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            arrays[f"W{i}"] = w
            arrays[f"b{i}"] = b
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        return buf.getvalue()

    @classmethod
    def from_bytes(cls, data: bytes) -> MLPPolicy:
        """The policy of `.npz` bytes; a ValueError if they are not a complete, sane file."""
        try:
            z = np.load(io.BytesIO(data), allow_pickle=False)
        except (zipfile.BadZipFile, ValueError, OSError, EOFError) as e:
            raise ValueError(
                f"MLPPolicy: not a readable .npz file ({type(e).__name__}: {e}); allowed: the "
                "numpy.savez file MLPPolicy.to_bytes writes"
            ) from None
        if not isinstance(z, np.lib.npyio.NpzFile):
            raise ValueError("MLPPolicy: a single .npy array; allowed: an .npz of named arrays")
        with z:
            n = sum(1 for k in z.files if re.fullmatch(r"W\d+", k))
            needed = ["obs_mean", "obs_std", "action_low", "action_high"]
            needed += [f"{p}{i}" for i in range(n) for p in "Wb"]
            missing = [k for k in needed if k not in z.files]
            allowed = "obs_mean, obs_std, W0, b0, W1, b1, ..., action_low, action_high"
            if missing or n == 0:
                raise ValueError(
                    f"MLPPolicy: missing arrays {missing or ['W0', 'b0']} (has {sorted(z.files)}); "
                    f"allowed: {allowed}"
                )
            # an array the policy would not use (a layer misnamed, a file of another format)
            unknown = sorted(set(z.files) - set(needed))
            if unknown:
                raise ValueError(
                    f"MLPPolicy: unknown arrays {unknown} (has {sorted(z.files)}); allowed: "
                    f"exactly {allowed}"
                )
            try:
                arrays = {k: z[k] for k in needed}
            except (zipfile.BadZipFile, ValueError, OSError, EOFError) as e:
                raise ValueError(
                    f"MLPPolicy: an array cannot be read ({type(e).__name__}: {e}); allowed: "
                    "the numpy.savez file MLPPolicy.to_bytes writes"
                ) from None
        for k, a in arrays.items():
            if a.dtype.kind not in "iuf":
                raise ValueError(f"MLPPolicy: {k} has dtype {a.dtype}; allowed: real numbers")
        return cls(
            arrays["obs_mean"],
            arrays["obs_std"],
            [arrays[f"W{i}"] for i in range(n)],
            [arrays[f"b{i}"] for i in range(n)],
            arrays["action_low"],
            arrays["action_high"],
        )

    @classmethod
    def load(cls, path: str | Path, sha256: str) -> MLPPolicy:
        """Load `path` after checking its bytes hash to `sha256` (a ValueError if not)."""
        data = Path(path).read_bytes()
        actual = hashlib.sha256(data).hexdigest()
        if actual != sha256:
            raise ValueError(
                f"MLPPolicy.load: weight file {str(path)!r} has sha256 {actual}; "
                f"allowed: the recorded {sha256}"
            )
        try:
            return cls.from_bytes(data)
        except ValueError as e:
            raise ValueError(f"MLPPolicy.load: weight file {str(path)!r}: {e}") from None


@njit(cache=True)
def _forward32(obs, flat, sizes):  # pragma: no cover (compiled)
    """`MLPPolicy.__call__`'s arithmetic for one observation, in plain loops; the result
    rounded to float32. `flat`/`sizes`: see `MLPPolicy.__init__`."""
    d0 = sizes[0]
    x = np.empty(d0)
    for i in range(d0):
        x[i] = (obs[i] - flat[i]) / flat[d0 + i]
    p = 2 * d0
    layers = len(sizes) - 1
    for k in range(layers):
        n_in, n_out = sizes[k], sizes[k + 1]
        bias = p + n_in * n_out
        z = np.empty(n_out)
        for j in range(n_out):
            acc = 0.0
            row = p + j * n_in
            for i in range(n_in):
                acc += flat[row + i] * x[i]
            z[j] = acc + flat[bias + j]
            if k < layers - 1:
                z[j] = math.tanh(z[j])
        p = bias + n_out
        x = z
    n = sizes[layers]
    out = np.empty(n, np.float32)
    for j in range(n):
        out[j] = flat[p + j] + (math.tanh(x[j]) + 1.0) * 0.5 * flat[p + n + j]
    return out
