"""Simulated people, standing in for a person in tests and examples, and human-DART noise.

`SimulatedHuman` is a delayed, noisy copy of the supervisor: when teleoperating it
executes the supervisor's label of the state `delay` steps back (the current one for the
first steps of an episode: a reaction time of `delay × dt`) plus Gaussian noise of standard
deviation `noise_std` (Box actions, clipped to the bounds) or, with probability
`epsilon`, another action (Discrete). When labelling retroactively there is no reaction to
wait for: its label is the supervisor's label of the shown state with the same noise.

`NoiseInjector` is `--noise`: the executed action is the person's intended action
with noise, fixed (`N(0, sigma² I)` or probability `epsilon` of another action) or
estimated as DART does, from how far a learner fit on the session's earlier episodes is from
the person's actions on the latest one (`fluids_bench.algos.dart.disagreement_covariance`),
optionally scaled to a target trace `alpha`. The intended action is what is recorded as the
label.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from fluids_bench.algos.actors import NoisySupervisorActor
from fluids_bench.core.validation import check_float, check_int


def _noisy(space: spaces.Space, action: Any, noise_std: float, epsilon: float, rng) -> Any:
    if isinstance(space, spaces.Discrete):
        return NoisySupervisorActor(space, epsilon=epsilon)(None, action, rng)
    dim = int(np.prod(space.shape))
    actor = NoisySupervisorActor(space, covariance=noise_std**2 * np.eye(dim))
    return actor(None, action, rng)


@dataclass
class SimulatedHuman:
    """A delayed (`delay` steps), noisy (`noise_std` / `epsilon`) supervisor."""

    delay: int = 2
    noise_std: float = 0.1
    epsilon: float = 0.05

    def __post_init__(self) -> None:
        check_int("SimulatedHuman", "delay", self.delay, 0)
        check_float("SimulatedHuman", "noise_std", self.noise_std, 0.0)
        check_float("SimulatedHuman", "epsilon", self.epsilon, 0.0, 1.0)
        self._labels: deque = deque()

    @classmethod
    def parse(cls, text: str) -> SimulatedHuman:
        """From `"delay=2,noise_std=0.1,epsilon=0.05"` (any subset; empty: the defaults)."""
        fields: dict[str, Any] = {}
        for part in filter(None, (p.strip() for p in text.split(","))):
            key, sep, value = part.partition("=")
            if not sep or key not in ("delay", "noise_std", "epsilon"):
                raise ValueError(
                    f"simulated human setting {part!r}; allowed: delay=INT, noise_std=FLOAT, "
                    "epsilon=FLOAT, separated by commas"
                )
            fields[key] = int(value) if key == "delay" else float(value)
        return cls(**fields)

    def reset(self) -> None:
        self._labels.clear()

    def act(self, space: spaces.Space, label: Any, rng: np.random.Generator) -> Any:
        """Teleoperation: the action for the state whose supervisor label is `label`."""
        self._labels.append(label)
        if len(self._labels) > self.delay + 1:
            self._labels.popleft()
        return _noisy(space, self._labels[0], self.noise_std, self.epsilon, rng)

    def label(self, space: spaces.Space, label: Any, rng: np.random.Generator) -> Any:
        """Retroactive labelling: the label for a shown state whose supervisor label is `label`."""
        return _noisy(space, label, self.noise_std, self.epsilon, rng)

    def describe(self) -> str:
        return (
            f"simulated human (supervisor delayed {self.delay} steps, noise_std "
            f"{self.noise_std}, epsilon {self.epsilon})"
        )


class NoiseInjector:
    """`--noise`: `level` (sigma for Box, epsilon for Discrete) or `"dart"`."""

    def __init__(
        self,
        space: spaces.Space,
        level: float | str | None,
        *,
        alpha: float | None = None,
        policy: str = "tree",
        initial: float = 0.0,
    ) -> None:
        self.space = space
        self.discrete = isinstance(space, spaces.Discrete)
        self.dart = level == "dart"
        self.alpha, self.policy = alpha, policy
        dim = 1 if self.discrete else int(np.prod(space.shape))
        if level is None:
            level = 0.0
        if self.dart:
            level = initial
        check_float("--noise", "level", float(level), 0.0, 1.0 if self.discrete else np.inf)
        self.epsilon = float(level) if self.discrete else 0.0
        self.covariance = None if self.discrete else float(level) ** 2 * np.eye(dim)

    @property
    def level(self) -> float:
        """Trace of the covariance (Box) or epsilon (Discrete): what the dataset records."""
        return self.epsilon if self.discrete else float(np.trace(self.covariance))

    @property
    def active(self) -> bool:
        return self.dart or self.level > 0

    def __call__(self, action: Any, rng: np.random.Generator) -> Any:
        if not self.active or self.level == 0:
            return action
        if self.discrete:
            return NoisySupervisorActor(self.space, epsilon=self.epsilon)(None, action, rng)
        return NoisySupervisorActor(self.space, covariance=self.covariance)(None, action, rng)

    def update(self, episodes: list[Any]) -> None:
        """DART: re-estimate the noise after an episode (from the second one on): fit the
        learner on all episodes but the last, measure its disagreement on the last."""
        if not self.dart or len(episodes) < 2:
            return
        from fluids_bench.algos.dart import (
            disagreement_covariance,
            disagreement_probability,
            scale_to_trace,
        )
        from fluids_bench.algos.policies import PolicySpec, fit_policy

        def pairs(eps):
            x = np.concatenate([np.asarray(e.observations[:-1]) for e in eps])
            y = np.concatenate([np.asarray(e.actions) for e in eps])
            return x.reshape(len(x), -1), y

        x, y = pairs(episodes[:-1])
        policy = fit_policy(PolicySpec(self.policy), self.space, x, y, random_state=0)
        xs, ys = pairs(episodes[-1:])
        predicted = policy.predict(xs)
        if self.discrete:
            self.epsilon = disagreement_probability(predicted, ys)
        else:
            cov = disagreement_covariance(predicted, ys)
            self.covariance = cov if self.alpha is None else scale_to_trace(cov, self.alpha)


def person(simulated: str | None, command: str = "this command") -> SimulatedHuman | None:
    """The labeller a command was asked for: a simulated person (`--simulated-human SPEC`), or
    `None` for a real one at a window, which needs pygame (`ValueError` naming the extra)
    and a real display (`ValueError` unless `FLUIDS_BENCH_HEADLESS=1`, see
    `fluids_bench.human.window.require_display`)."""
    if simulated is not None:
        return SimulatedHuman.parse(simulated)
    from fluids_bench.human.window import require_display, require_pygame

    try:
        require_pygame()
    except ImportError as exc:
        raise ValueError(str(exc)) from None
    require_display(command)
    return None
