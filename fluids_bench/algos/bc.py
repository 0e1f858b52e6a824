"""Behavior Cloning (ch. 2, "Off-Policy Sampling").

The supervisor tele-operates: the sampling distribution is `p(u | x, psi) = delta(pi*(x))`.
Its demonstrations are aggregated and the learner minimises the empirical surrogate loss

    theta^R = argmin_theta sum_n J(theta, theta* | xi_n),   xi_n ~ p(xi | theta*)

(ch. 1, with `J` the summed per-step loss). Each iteration adds `demos_per_iteration`
demonstrations, subsampled by the ch. 3 protocol.
"""

from __future__ import annotations

from dataclasses import dataclass

from fluids_bench.algos.actors import SUPERVISOR
from fluids_bench.algos.config import RunConfig
from fluids_bench.algos.harness import Harness, ProgressCallback
from fluids_bench.algos.results import RunResult


@dataclass(frozen=True, kw_only=True)
class BCConfig(RunConfig):
    """Behavior Cloning has no settings beyond `RunConfig`."""


def run(config: BCConfig, progress: ProgressCallback | None = None) -> RunResult:
    with Harness("bc", config, progress) as harness:
        for iteration in range(1, config.iterations + 1):
            demos = harness.collect_many(SUPERVISOR, config.demos_per_iteration)
            for demo in demos:
                harness.aggregate(demo)
            harness.record(iteration, demos)
        return harness.result()
