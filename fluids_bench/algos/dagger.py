"""DAgger and DAgger-B (ch. 2, "On-Policy Sampling"; ch. 3 experiments).

DAgger is Follow-The-Leader on the aggregate of on-policy data (Ross et al., 2011):

    theta^{k+1} = argmin_theta sum_{i=1}^{k} E_{p(xi | theta^i)} J(theta, theta* | xi)

At iteration `k` the executed policy is the mixture `pi_k = beta_k pi* + (1 - beta_k) pi_theta^k`
(drawn every step), every visited state is labelled by the supervisor, and the learner is
refit on all data. Two common variants are built in: an initial set of supervisor
demonstrations (`initial_demos`, the source always uses one) and a beta schedule:

- `constant`: `beta_k = beta` (`beta = 0` is pure on-policy, the source's Theorem 1 case;
  `beta = 1` collects exactly what Behavior Cloning collects);
- `exponential`: `beta_k = beta^k` (Ross et al.'s `p^{k-1}` decay, shifted because the
  initial demonstrations already play the role of `beta_1 = 1`).

DAgger-B (ch. 3) refits the learner only after the iterations listed in `retrain_at`, or
after every `retrain_every`-th iteration (which then replaces `retrain_at`), and after the
initial demonstrations, trading performance for compute. The source's Humanoid protocol, "60
initial demonstrations, then an update every 15 iterations", is `initial_demos=60,
retrain_every=15`; its ch. 3 DAgger is `beta=0.5, beta_schedule="exponential"`.
"""

from __future__ import annotations

from dataclasses import dataclass

from fluids_bench.algos.actors import SUPERVISOR, LearnerActor, MixtureActor
from fluids_bench.algos.config import RunConfig, check_iterations
from fluids_bench.algos.harness import Harness, ProgressCallback
from fluids_bench.algos.results import RunResult
from fluids_bench.core.validation import check_choice, check_float, check_int

BETA_SCHEDULES = ("constant", "exponential")


@dataclass(frozen=True, kw_only=True)
class DAggerConfig(RunConfig):
    """`retrain_at=None` and `retrain_every=None` refit every iteration (DAgger); either
    gives DAgger-B (`retrain_every` wins when both are set)."""

    beta: float = 0.0
    beta_schedule: str = "constant"
    initial_demos: int = 1
    retrain_at: tuple[int, ...] | None = None
    retrain_every: int | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        where = type(self).__name__
        check_float(where, "beta", self.beta, 0.0, 1.0)
        check_choice(where, "beta_schedule", self.beta_schedule, BETA_SCHEDULES)
        check_int(where, "initial_demos", self.initial_demos, 1)
        if self.retrain_at is not None:
            check_iterations(where, "retrain_at", self.retrain_at)
        if self.retrain_every is not None:
            check_int(where, "retrain_every", self.retrain_every, 1)

    @property
    def batched(self) -> bool:
        """DAgger-B: the learner is not refit after every iteration."""
        return self.retrain_at is not None or self.retrain_every is not None


def beta_at(config: DAggerConfig, iteration: int) -> float:
    """The probability of executing the supervisor's action at `iteration` (>= 1)."""
    if config.beta_schedule == "exponential":
        return config.beta**iteration
    return config.beta


def refits_at(config: DAggerConfig, iteration: int) -> bool:
    """Whether the learner is refit after `iteration` (>= 1)."""
    if config.retrain_every is not None:
        return iteration % config.retrain_every == 0
    return config.retrain_at is None or iteration in config.retrain_at


def run(config: DAggerConfig, progress: ProgressCallback | None = None) -> RunResult:
    algo = "dagger_b" if config.batched else "dagger"
    with Harness(algo, config, progress) as harness:
        # iteration 0: supervisor demonstrations initialise the aggregate dataset
        demos = harness.collect_many(SUPERVISOR, config.initial_demos)
        for demo in demos:
            harness.aggregate(demo)
        policy = harness.fit()
        harness.record(0, demos, beta=1.0)

        for iteration in range(1, config.iterations + 1):
            beta = beta_at(config, iteration)
            actor = MixtureActor(beta, LearnerActor(policy))
            rollouts = harness.collect_many(actor, config.demos_per_iteration)
            for trajectory in rollouts:
                harness.aggregate(trajectory)  # the supervisor labels every visited state
            if refits_at(config, iteration):
                policy = harness.fit()
            harness.record(iteration, rollouts, beta=beta)
        return harness.result()
