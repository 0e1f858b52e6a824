"""Isotropic noise injection (ch. 2, "Noise Injection"; the "Isotropic-Gaussian" baseline of ch. 3).

Off-policy sampling from a widened supervisor: `u = pi*(x) + eps`. For Box actions
`eps ~ N(0, noise_std^2 I)` (the source's baseline uses `Sigma = I`); for Discrete actions
the supervisor's action is replaced by a uniformly drawn other action with probability
`epsilon`. The noise forces the supervisor into recoverable mistakes, so its labels include
corrective examples; the learner is then fit on the aggregate data as in Behavior Cloning.
The noise never changes; DART (`fluids_bench.algos.dart`) chooses it from data.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from fluids_bench.algos.actors import NoisySupervisorActor
from fluids_bench.algos.config import RunConfig
from fluids_bench.algos.harness import Harness, ProgressCallback
from fluids_bench.algos.results import RunResult
from fluids_bench.core.validation import check_float


@dataclass(frozen=True, kw_only=True)
class NoiseConfig(RunConfig):
    """`noise_std` applies to Box actions, `epsilon` to Discrete ones."""

    noise_std: float = 1.0
    epsilon: float = 0.1

    def __post_init__(self) -> None:
        super().__post_init__()
        where = type(self).__name__
        check_float(where, "noise_std", self.noise_std, 0.0)
        check_float(where, "epsilon", self.epsilon, 0.0, 1.0)


def isotropic_actor(
    action_space: spaces.Space[Any], noise_std: float, epsilon: float
) -> NoisySupervisorActor:
    """The supervisor with `N(0, noise_std^2 I)` noise (Box) or `epsilon`-random (Discrete)."""
    if isinstance(action_space, spaces.Discrete):
        return NoisySupervisorActor(action_space, epsilon=epsilon)
    dim = int(np.prod(action_space.shape))
    return NoisySupervisorActor(action_space, covariance=noise_std**2 * np.eye(dim))


def run(config: NoiseConfig, progress: ProgressCallback | None = None) -> RunResult:
    with Harness("noise", config, progress) as harness:
        actor = isotropic_actor(harness.action_space, config.noise_std, config.epsilon)
        for iteration in range(1, config.iterations + 1):
            demos = harness.collect_many(actor, config.demos_per_iteration)
            for demo in demos:
                harness.aggregate(demo)  # labels are the supervisor's, not the noisy actions
            harness.record(iteration, demos)
        return harness.result()
