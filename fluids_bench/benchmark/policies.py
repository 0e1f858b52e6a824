"""The policies `evaluate` accepts, and how a worker acts with one.

A policy is given as a spec string (the command line's `--policy`) or as an object:

| spec | policy |
| --- | --- |
| `random` | uniform random actions (the score's 0), drawn from the episode's seed |
| `supervisor` | the env's supervisor label (the score's 1) |
| `module:factory` | `factory()` (or `factory(task)` if it takes an argument) returns an object with `act(obs)` or `predict(obs_batch)` |
| `PATH.json` | a `fluids-bench train` result: a scikit-learn family's run is deterministic, so it is run again from its config to rebuild the learner it ended with (the JSON stores no model); a `module:factory` learner's run is read from the checkpoint `train` saved next to it, `PATH` with `.learner.npz` for `.json` |
| `PATH.zip` | a stable-baselines3 model (needs the `train` extra; SB3's own format unpickles parts of the file: load only files you trust) |
| other `PATH` | a learner checkpoint read by `fluids_bench.algos.learners.load_learner` (safe formats only) |

An object (from Python) needs `act(obs) -> action` or `predict(obs_batch) -> actions`.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from fluids_bench.algos.vector_rollout import DEFAULT_BATCH, has_vector_env, run_vector_episodes
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY, supervisor_action

BUILT_INS = ("random", "supervisor")
SB3_ALGORITHMS = ("PPO", "SAC", "TD3", "A2C", "DQN", "DDPG")
ACTOR_STREAM = 0xE7A1  # the random policy's generator: [seed, ACTOR_STREAM]


@dataclass
class PolicySource:
    """A resolved policy: what a worker needs to act (picklable).

    Attributes:
        name: the policy's name in files and scorecards.
        kind: `"random"`, `"supervisor"`, `"factory"`, `"object"`, `"sb3"` or `"learner"`.
        spec: the spec string it came from (None for an object).
        obj: the policy object (`"object"`) or a loaded learner built in the calling process.
        extras: what the scorecard reports about it (e.g. a train run's label-efficiency).
    """

    name: str
    kind: str
    spec: str | None = None
    obj: Any = None
    extras: dict[str, Any] = field(default_factory=dict)

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "kind": self.kind, "spec": self.spec, **self.extras}


class _Act:
    """`act(obs)` of any policy object: its `act`, or `predict` on a batch of one."""

    def __init__(self, policy: Any) -> None:
        # a predict-only policy acts on batches: stateless, so episodes may share its calls
        self.predicts = not hasattr(policy, "act")
        if hasattr(policy, "act"):
            self._fn = policy.act
        elif hasattr(policy, "predict"):
            self._fn = lambda obs: _first(policy.predict(np.asarray(obs)[None]))
        else:
            raise ValueError(
                f"policy {type(policy).__name__} has neither act(obs) nor predict(obs_batch); "
                "allowed: an object with one of them"
            )

    def __call__(self, obs: Any, info: dict[str, Any], env: Any, rng: Any) -> Any:
        return self._fn(obs)


def _first(batch: Any) -> Any:
    if isinstance(batch, tuple):  # an SB3-like predict: (actions, states)
        batch = batch[0]
    return np.asarray(batch)[0]


class _SB3Act:
    def __init__(self, model: Any) -> None:
        self.model = model

    def __call__(self, obs: Any, info: dict[str, Any], env: Any, rng: Any) -> Any:
        return self.model.predict(obs, deterministic=True)[0]


def random_action(space: spaces.Space[Any], rng: np.random.Generator) -> Any:
    """A uniform action of `space` (Box with finite bounds, Discrete) from `rng`."""
    if isinstance(space, spaces.Discrete):
        return int(space.start + rng.integers(space.n))
    if isinstance(space, spaces.Box):
        if not (np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high))):
            raise ValueError(f"random policy: action space {space} is unbounded")
        return rng.uniform(space.low, space.high).astype(space.dtype)
    raise ValueError(f"random policy: action space {space}; allowed: Box or Discrete")


def _random(obs: Any, info: dict[str, Any], env: Any, rng: np.random.Generator) -> Any:
    return random_action(env.action_space, rng)


def _supervisor(obs: Any, info: dict[str, Any], env: Any, rng: Any) -> Any:
    if SUPERVISOR_ACTION_KEY in info:
        return info[SUPERVISOR_ACTION_KEY]
    return supervisor_action(env)


def batchable(source: PolicySource, actor: Any) -> bool:
    """Whether episodes of `source` (acting as `actor`, `build_actor`'s) may be stepped
    together on a vector env: random, the supervisor, SB3 models, learners (train results and
    checkpoints) and policies with only `predict`; not an object with `act`, which may keep
    state from one step of its episode to the next."""
    if source.kind in ("random", "supervisor", "sb3", "learner"):
        return True
    return isinstance(actor, _Act) and actor.predicts


def batch_actor(source: PolicySource, actor: Any) -> Any:
    """`(space, observations, labels, rngs) -> actions` of the episodes stepped together
    (`fluids_bench.algos.vector_rollout.BatchActor`): each episode's action is the one
    `actor` gives it alone (a policy is called on one observation at a time, as in a
    scalar episode, so its actions are the same bit for bit)."""
    if source.kind == "random":
        return lambda space, observations, labels, rngs: [random_action(space, r) for r in rngs]
    if source.kind == "supervisor":
        return lambda space, observations, labels, rngs: labels
    return lambda space, observations, labels, rngs: [
        actor(obs, {}, None, rng) for obs, rng in zip(observations, rngs, strict=True)
    ]


def actor_rng(seed: int) -> np.random.Generator:
    """The generator a policy may draw from in the episode with `seed` (random's actions)."""
    return np.random.default_rng([seed, ACTOR_STREAM])


def build_actor(source: PolicySource, task: Any) -> Any:
    """A callable `(obs, info, env, rng) -> action` for `source` on `task` (in a worker)."""
    if source.kind == "random":
        return _random
    if source.kind == "supervisor":
        return _supervisor
    if source.kind == "factory":
        return _Act(_call_factory(source.spec, task))
    if source.kind == "sb3":
        return _SB3Act(load_sb3(source.spec))
    if source.kind in ("object", "learner"):
        return _Act(source.obj)
    raise ValueError(f"unknown policy kind {source.kind!r}")


def _load_factory(spec: str) -> Any:
    module_name, _, attr = spec.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ValueError(f"--policy {spec!r}: cannot import module {module_name!r}: {exc}") from exc
    factory = getattr(module, attr, None)
    if not callable(factory):
        raise ValueError(f"--policy {spec!r}: module {module_name!r} has no callable {attr!r}")
    return factory


def _call_factory(spec: str, task: Any) -> Any:
    factory = _load_factory(spec)
    try:
        takes_task = len(inspect.signature(factory).parameters) > 0
    except (TypeError, ValueError):
        takes_task = False
    return factory(task) if takes_task else factory()


def load_sb3(path: str) -> Any:
    """A stable-baselines3 model from `path`, trying its algorithms in turn."""
    try:
        import stable_baselines3 as sb3
    except ImportError as exc:
        raise ImportError(
            f"--policy {path}: an SB3 model needs stable-baselines3: pip install "
            f"'fluids-bench[train]' ({exc})"
        ) from exc
    errors = []
    for name in SB3_ALGORITHMS:
        try:
            return getattr(sb3, name).load(path, device="cpu")
        except Exception as exc:  # noqa: BLE001  (the next algorithm may read it)
            errors.append(f"{name}: {type(exc).__name__}")
    raise ValueError(f"--policy {path}: not a stable-baselines3 model ({'; '.join(errors)})")


def is_train_result(path: Path) -> bool:
    """Whether `path` is a `fluids-bench train` result JSON."""
    if path.suffix != ".json" or not path.is_file():
        return False
    try:
        data = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return False
    return isinstance(data, dict) and "algo" in data and isinstance(data.get("config"), dict)


def resolve(policy: Any, name: str | None = None) -> PolicySource:
    """A [`PolicySource`][fluids_bench.benchmark.policies.PolicySource] for a spec or object.

    A complete train result's learner is rebuilt (trained again) only when an episode needs it
    ([`ensure_learner`][fluids_bench.benchmark.policies.ensure_learner], in the calling
    process); a `PolicySource` (e.g. from
    [`train_result_source`][fluids_bench.benchmark.policies.train_result_source]) is used as is.
    A user learner's run (`--policy module:factory`) loads the learner its run saved.
    """
    if isinstance(policy, PolicySource):
        return policy
    if not isinstance(policy, str):
        _Act(policy)  # refuses an object without act / predict now
        return PolicySource(name or type(policy).__name__, "object", None, policy)
    if policy in BUILT_INS:
        return PolicySource(name or policy, policy, policy)
    path = Path(policy)
    if path.suffix == ".zip":
        if not path.is_file():
            raise FileNotFoundError(f"--policy {policy}: no such SB3 model file")
        return PolicySource(name or path.stem, "sb3", str(path))
    if path.suffix == ".json":
        if not is_train_result(path):
            raise ValueError(
                f"--policy {policy}: not a `fluids-bench train` result (a JSON with 'algo' and "
                "'config')"
            )
        return _from_train_result(path, name)
    if path.exists():
        try:
            from fluids_bench.algos.learners import load_learner  # the learners' checkpoints
        except ImportError as exc:
            raise ValueError(
                f"--policy {policy}: a learner checkpoint needs "
                f"fluids_bench.algos.learners.load_learner, not available here ({exc})"
            ) from exc
        return PolicySource(name or path.stem, "learner", str(path), load_learner(path))
    if ":" in policy:
        _load_factory(policy)  # refuses a bad spec now, not in a worker
        return PolicySource(name or policy.replace(":", "."), "factory", policy)
    raise ValueError(
        f"--policy {policy!r}; allowed: random, supervisor, module:factory, a train result "
        "(.json), an SB3 model (.zip) or a learner checkpoint path"
    )


def harness_eval_seeds(config: Any) -> list[int]:
    """The evaluation seeds of a train run with `config`, drawn as
    [`Harness`][fluids_bench.algos.harness.Harness] draws them (its second seed stream;
    tested against the harness)."""
    from fluids_bench.algos.harness import SEED_BOUND

    stream = np.random.SeedSequence(config.seed).spawn(5)[1]
    draws = np.random.default_rng(stream).integers(SEED_BOUND, size=config.eval_episodes)
    return [int(s) for s in draws]


def random_return(
    env_id: str, env_kwargs: dict[str, Any], seeds: list[int], batch: int = DEFAULT_BATCH
) -> float:
    """The random policy's mean return over `seeds` (whole episodes), stepped `batch` at a
    time on the id's vector env where it has one (the same sum, in the same order)."""
    if batch == 1 or not has_vector_env(env_id) or not seeds:
        return _random_return_alone(env_id, env_kwargs, seeds)
    ends: dict[int, list[float]] = {}
    run_vector_episodes(
        env_id, env_kwargs, seeds,
        lambda space, observations, labels, rngs: [random_action(space, r) for r in rngs],
        actor_rng, lambda end: ends.__setitem__(end.index, end.rewards), batch=batch,
    )  # fmt: skip
    total = 0.0
    for i in range(len(seeds)):
        for reward in ends[i]:
            total += reward
    return total / len(seeds)


def _random_return_alone(env_id: str, env_kwargs: dict[str, Any], seeds: list[int]) -> float:
    import gymnasium as gym

    env = gym.make(env_id, **env_kwargs)
    total = 0.0
    for seed in seeds:
        env.reset(seed=seed)
        rng, done = actor_rng(seed), False
        while not done:
            _, reward, terminated, truncated, _ = env.step(random_action(env.action_space, rng))
            total += float(reward)
            done = terminated or truncated
    env.close()
    return total / len(seeds)


def _from_train_result(path: Path, name: str | None) -> PolicySource:
    return train_result_source(path, name)


def train_result_source(
    path: str | Path, name: str | None = None, result: Any = None
) -> PolicySource:
    """The policy of a `fluids-bench train` result, with the run's label-efficiency curve.

    The JSON stores no model, but its run is deterministic: the learner is the one its config
    trains. `result` (the run's `RunResult`, for a caller that has just run it) supplies it at
    once; otherwise a complete result's learner is rebuilt by running the config again when an
    episode needs it ([`ensure_learner`][fluids_bench.benchmark.policies.ensure_learner]), and
    an incomplete one (`"complete": false`) is run again here. The curve is each evaluated
    iteration's mean return on the run's own evaluation seeds, normalised by the supervisor's
    (from the run) and the random policy's (measured here) on those same seeds.

    Args:
        path: the train result `.json`.
        name: the policy's name (default: the file's stem).
        result: the `RunResult` of that JSON's run, if the caller holds it.

    Returns:
        A `"learner"` source (its `obj` None until built when neither `result` is given nor the
        JSON is incomplete).
    """
    path = Path(path)
    data = json.loads(path.read_text())
    if isinstance(data["config"].get("policy"), dict) and "learner" in data["config"]["policy"]:
        return _from_learner_run(path, data, name)
    config = _train_config(path, data)
    if result is None and not data.get("complete", False):
        result = _train_again(data["algo"], config)
    records = data.get("records", [])
    if result is not None:
        records = [dataclasses.asdict(r) for r in result.records]
        supervisor, labels = result.supervisor_return, result.final.labels_requested
    else:
        supervisor, labels = data["supervisor_return"], records[-1]["labels_requested"]
    evaluated = [r for r in records if r.get("eval_return") is not None]
    extras = _run_extras(path, data, config, labels, evaluated, supervisor)
    learner = None if result is None else result.policy
    return PolicySource(name or path.stem, "learner", str(path), learner, extras)


def ensure_learner(source: PolicySource) -> PolicySource:
    """Build a train result's learner if it is not built yet (runs its config again)."""
    if source.kind == "learner" and source.obj is None and "train_result" in source.extras:
        path = Path(source.extras["train_result"])
        data = json.loads(path.read_text())
        source.obj = _train_again(data["algo"], _train_config(path, data)).policy
    return source


def _train_config(path: Path, data: dict[str, Any]) -> Any:
    """The config of a train result's run, in this process (one worker, no checkpoint)."""
    from fluids_bench.algos.policies import PolicySpec
    from fluids_bench.algos.registry import get_algorithm

    algorithm = get_algorithm(data["algo"])
    settings = dict(data["config"])
    fields = {f.name: f for f in dataclasses.fields(algorithm.config_class)}
    unknown = sorted(set(settings) - set(fields))
    if unknown:
        raise ValueError(f"--policy {path}: config fields {unknown} are not {data['algo']}'s")
    policy = settings.get("policy")
    if isinstance(policy, dict):
        settings["policy"] = PolicySpec(**policy)
    for key, value in settings.items():
        if isinstance(value, list):
            settings[key] = tuple(value)
    settings.update(workers=1, backend="process", checkpoint=None)
    settings = {k: v for k, v in settings.items() if k in fields}
    return algorithm.config_class(**settings)


def _train_again(algo: str, config: Any) -> Any:
    from fluids_bench.algos.registry import get_algorithm

    return get_algorithm(algo).run(config, None)


def _run_extras(
    path: Path,
    data: dict[str, Any],
    config: Any,
    labels: int,
    records: list[dict[str, Any]],
    supervisor: float | None,
) -> dict[str, Any]:
    """What a scorecard says about a train run: where it is, its env, seed and labels, and its
    label-efficiency curve (normalised on the run's own evaluation seeds)."""
    extras: dict[str, Any] = {
        "train_result": str(path),
        "algo": data["algo"],
        "env_id": config.env_id,
        "env_kwargs": dict(config.env_kwargs),
        "train_seed": config.seed,
        "labels_used": labels,
    }
    if not records or supervisor is None:
        return extras
    random = random_return(config.env_id, dict(config.env_kwargs), harness_eval_seeds(config))
    if supervisor > random:
        extras["learning_curve"] = {
            "labels": [r["labels_requested"] for r in records],
            "normalised_performance": [
                (r["eval_return"] - random) / (supervisor - random) for r in records
            ],
            "random_return": random,
            "supervisor_return": supervisor,
        }
    return extras


def learner_checkpoint(path: Path) -> Path:
    """Where `fluids-bench train` saves the final learner of the run whose result is `path`."""
    return path.with_name(path.stem + ".learner.npz")


def _from_learner_run(path: Path, data: dict[str, Any], name: str | None) -> PolicySource:
    """A train result of a user learner (`--policy module:factory`): a run is not replayed
    (the factory need not be deterministic), its saved final learner is loaded."""
    from types import SimpleNamespace

    if not data.get("complete"):
        raise ValueError(
            f"--policy {path}: the run is not complete (complete: false); allowed: a finished "
            "run (`fluids-bench train ... --resume` finishes it)"
        )
    checkpoint = learner_checkpoint(path)
    if not checkpoint.is_file():
        raise ValueError(
            f"--policy {path}: a run of learner {data['config']['policy']['learner']!r} is "
            f"evaluated from the learner `train` saved next to it, {checkpoint}, which is missing"
        )
    from fluids_bench.algos.learners import load_learner

    learner = load_learner(checkpoint)
    settings = data["config"]
    config = SimpleNamespace(
        env_id=settings["env_id"],
        env_kwargs=dict(settings.get("env_kwargs") or {}),
        seed=int(settings["seed"]),
        eval_episodes=int(settings["eval_episodes"]),
    )
    records = [r for r in data.get("records", []) if r.get("eval_return") is not None]
    labels = int(data["records"][-1]["labels_requested"]) if data.get("records") else 0
    extras = _run_extras(path, data, config, labels, records, data.get("supervisor_return"))
    extras["learner"] = settings["policy"]["learner"]
    extras["learner_checkpoint"] = str(checkpoint)
    return PolicySource(name or path.stem, "learner", str(path), learner, extras)
