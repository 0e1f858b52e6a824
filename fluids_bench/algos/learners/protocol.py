"""The learner protocol: what an algorithm needs from a model it trains.

A learner is any object with `fit(observations, labels)` and `predict(observations)`
(`Learner`). Every algorithm (BC, DAgger, DAgger-B, noise injection, DART, SHIV, OGD)
accepts one in place of a scikit-learn `PolicySpec` through `RunConfig.policy`:

- `observations` is the batch of the env's observations as the env returns them, shape
  `(n, *observation_space.shape)` (images stay `(n, H, W, 3)` uint8; nothing is flattened);
- `labels` are the supervisor's actions: int64 `(n,)` for a Discrete action space, float
  `(n, *action_space.shape)` for a Box one;
- `predict` returns one action per row in the same layout; the algorithms cast Discrete
  predictions to int64 and clip Box ones to the action bounds (`LearnerPolicy`);
- `fit` is called on the whole aggregate dataset each time the algorithm refits (DAgger once an
  iteration): a learner may keep its weights between calls (warm start) or start afresh.

Optional: a learner with `set_spaces(observation_space, action_space)` is told the env's spaces
once, before its first fit (the torch learners size their output layer from it). OGD calls
`partial_fit(observations, labels)` when the learner has it, else `fit`, with only the latest
iteration's on-policy pairs (a warm-started learner then descends on the latest loss from where
it stands, which is OGD's step).

What the algorithms need beyond fit/predict: nothing. DART estimates its noise from `predict`
on its held-out states; SHIV's risk model calls `predict` on the training states to split them
into well- and mispredicted ones and fits its own One-Class SVMs on the flattened observations.
For rollouts on several worker processes (`workers > 1`) the learner must pickle (torch modules
do); with `workers=1` it never leaves the process.
"""

from __future__ import annotations

import importlib
import json
import os
import sys
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import numpy as np
from gymnasium import spaces


@runtime_checkable
class Learner(Protocol):
    """A model an imitation-learning algorithm can train: `fit` then `predict`."""

    def fit(self, observations: np.ndarray, labels: np.ndarray) -> Any:
        """Fit on state–label pairs (row `i` of `labels` labels row `i` of `observations`)."""
        ...

    def predict(self, observations: np.ndarray) -> np.ndarray:
        """One action per row of `observations`."""
        ...


class Policy(Protocol):
    """Anything that maps observations to actions: a fitted estimator or a hand-made learner."""

    def predict(self, observations: np.ndarray) -> np.ndarray:
        """Actions for a batch of observations."""
        ...

    def act(self, observation: np.ndarray) -> Any:
        """The action for one observation."""
        ...


LearnerFactory = Callable[[], Learner]


def check_action_space(action_space: spaces.Space[Any]) -> bool:
    """True for Discrete actions, False for Box; anything else is refused."""
    if isinstance(action_space, spaces.Discrete):
        return True
    if isinstance(action_space, spaces.Box):
        return False
    raise ValueError(
        f"action space {action_space} is not supported; allowed: Discrete or Box action spaces"
    )


def features(observations: np.ndarray) -> np.ndarray:
    """Flatten a batch of Box observations to a float64 feature matrix."""
    batch = np.asarray(observations, dtype=np.float64)
    return batch.reshape(batch.shape[0], -1)


def is_learner(value: Any) -> bool:
    """Whether `value` is a learner instance (a class with fit/predict is a factory)."""
    return not isinstance(value, type) and isinstance(value, Learner)


def check_learner(value: Any, where: str) -> Learner:
    """`value` if it has callable `fit` and `predict`; else a ValueError naming `where`."""
    if not is_learner(value):
        raise ValueError(
            f"{where}: {value!r} is not a learner; allowed: an object with fit(observations, "
            "labels) and predict(observations) (fluids_bench.algos.learners.Learner)"
        )
    return value


def make_learner(source: Any, where: str) -> Learner:
    """A learner from `source`: a learner itself, or a factory (a class or a zero-argument
    callable) that returns one."""
    if is_learner(source):
        return source
    if not callable(source):
        raise ValueError(
            f"{where}: {source!r} is neither a learner nor a factory; allowed: an object with "
            "fit/predict, or a zero-argument callable returning one"
        )
    return check_learner(source(), f"{where} (what {describe_source(source)} returned)")


def describe_source(source: Any) -> str:
    """A JSON-friendly name of a learner or factory, for records and checkpoint keys: its own
    `describe()` when it has one, else `module:qualname` (of the class for an instance)."""
    describe = getattr(source, "describe", None)
    if callable(describe) and not isinstance(source, type):
        return str(describe())
    target = type(source) if is_learner(source) else source
    name = getattr(target, "__qualname__", None)
    return repr(target) if name is None else f"{target.__module__}:{name}"


def resolve_factory(spec: str) -> Callable[[], Any]:
    """The object named by `"module:attribute"` (a learner factory), imported; a clear error
    when the text is not of that form, the module does not import or lacks the attribute."""
    module_name, sep, attribute = spec.partition(":")
    if not sep or not module_name or not attribute:
        raise ValueError(
            f"--policy {spec!r} is not a learner factory; allowed: a scikit-learn family "
            "name or 'module:factory' (a zero-argument callable returning a learner)"
        )
    if os.getcwd() not in sys.path and "" not in sys.path:
        # as `python -m` does: a module next to where the command runs imports (the console
        # script's own sys.path starts at its bin folder)
        sys.path.append(os.getcwd())
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ValueError(
            f"--policy {spec!r}: module {module_name!r} does not import: {exc}"
        ) from exc
    target: Any = module
    for part in attribute.split("."):
        if not hasattr(target, part):
            raise ValueError(
                f"--policy {spec!r}: module {module_name!r} has no attribute {attribute!r}"
            )
        target = getattr(target, part)
    if not callable(target):
        raise ValueError(f"--policy {spec!r}: {attribute!r} is not callable; allowed: a factory")
    return target


class LearnerPolicy:
    """A fitted learner as the algorithms' policy: actions in `action_space`'s layout.

    It reads the learner at call time (no copy): after the learner is refit, an older
    `LearnerPolicy` of it predicts with the new weights.
    """

    def __init__(self, learner: Learner, action_space: spaces.Space[Any]) -> None:
        self.learner = learner
        self.action_space = action_space
        self.discrete = check_action_space(action_space)

    def predict(self, observations: np.ndarray) -> np.ndarray:
        """Actions for a batch (Discrete: int64 `(n,)`; Box: `(n, *shape)`, clipped)."""
        n = len(observations)
        raw = np.asarray(self.learner.predict(np.asarray(observations)))
        if len(raw) != n:
            raise ValueError(
                f"learner {describe_source(self.learner)}: predict returned {len(raw)} actions "
                f"for {n} observations; allowed: one per row"
            )
        if self.discrete:
            return raw.astype(np.int64).reshape(n)
        actions = raw.astype(self.action_space.dtype).reshape((n, *self.action_space.shape))
        return np.clip(actions, self.action_space.low, self.action_space.high)

    def act(self, observation: np.ndarray) -> Any:
        """The action for one observation."""
        return self.predict(np.asarray(observation)[None])[0]


class NamedFactory:
    """`fluids-bench train --policy module:factory --policy-param k=v`: the factory named by
    `spec`, called with `params` as keyword arguments; records name it by its text, so a
    resumed run recognises it. Pickles by name (worker processes import it again)."""

    def __init__(self, spec: str, params: dict[str, Any] | None = None) -> None:
        self.spec = spec
        self.params = dict(params or {})
        self.factory = resolve_factory(spec)

    def __call__(self) -> Learner:
        try:
            learner = self.factory(**self.params)
        except TypeError as exc:
            raise ValueError(f"--policy {self.spec!r} with {self.params}: {exc}") from exc
        return check_learner(learner, f"--policy {self.spec!r} (what it returned)")

    def describe(self) -> str:
        if not self.params:
            return self.spec
        return f"{self.spec} {json.dumps(self.params, sort_keys=True)}"

    def __reduce__(self) -> tuple[Any, ...]:
        return (NamedFactory, (self.spec, self.params))
