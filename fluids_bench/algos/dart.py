"""DART: Disturbances Augmenting Robot Training (ch. 3, "DART").

Noise injection whose noise is fit to the learner's own errors. With the source's three
approximations (mean at the supervisor, expectation over the sampling distribution, one
sample of the current learner), the covariance update is Eq. 3:

    Sigma_{k+1} = 1/T E_{p(xi | psi_k)} sum_t (pi_theta^k(x_t) - pi*(x_t)) (pi_theta^k(x_t) - pi*(x_t))^T

estimated here on the held-out pairs of the rollouts collected under the current noise
``psi_k`` (pairs the learner was not trained on). Optionally the magnitude is set by a prior:

    Sigma^alpha_{k+1} = alpha / tr(Sigma_{k+1}) Sigma_{k+1}

For Discrete actions the same estimate is the probability that the learner disagrees with
the supervisor; the supervisor then executes another action with that probability.

Loop: collect ``demos_per_iteration`` noise-injected demonstrations per iteration; after the
iterations in ``update_at`` fit the learner and re-estimate the noise. The learner is not
refit in between, which is where DART saves compute over DAgger.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fluids_bench.algos.actors import NoisySupervisorActor
from fluids_bench.algos.config import RunConfig, check_iterations
from fluids_bench.algos.harness import Harness, ProgressCallback
from fluids_bench.algos.noise import isotropic_actor
from fluids_bench.algos.results import RunResult
from fluids_bench.core.validation import check_float


@dataclass(frozen=True, kw_only=True)
class DARTConfig(RunConfig):
    """``alpha=None`` keeps the estimated magnitude; ``heldout_fraction`` = 0 holds out only
    the pairs the ch. 3 subsampling leaves over (the state-level experiment uses 0.1)."""

    alpha: float | None = None
    update_at: tuple[int, ...] = (2, 8)
    heldout_fraction: float = 0.0
    initial_noise_std: float = 0.0
    initial_epsilon: float = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        where = type(self).__name__
        if self.alpha is not None:
            check_float(where, "alpha", self.alpha, 0.0)
        check_iterations(where, "update_at", self.update_at)
        check_float(where, "heldout_fraction", self.heldout_fraction, 0.0, 1.0, hi_open=True)
        check_float(where, "initial_noise_std", self.initial_noise_std, 0.0)
        check_float(where, "initial_epsilon", self.initial_epsilon, 0.0, 1.0)


def disagreement_covariance(learner: np.ndarray, supervisor: np.ndarray) -> np.ndarray:
    """Eq. 3 on samples: the mean of ``d d^T`` with ``d = learner - supervisor`` per pair.

    It is a second moment about the supervisor (Approximation 1), not about the mean of ``d``.
    """
    d = np.asarray(learner, dtype=np.float64).reshape(len(learner), -1)
    d = d - np.asarray(supervisor, dtype=np.float64).reshape(len(supervisor), -1)
    return d.T @ d / len(d)


def scale_to_trace(covariance: np.ndarray, alpha: float) -> np.ndarray:
    """``alpha / tr(Sigma) Sigma``; a zero covariance stays zero (no direction to scale)."""
    trace = float(np.trace(covariance))
    return covariance if trace == 0.0 else covariance * (alpha / trace)


def disagreement_probability(learner: np.ndarray, supervisor: np.ndarray) -> float:
    """The Discrete analogue of Eq. 3: how often the learner's action differs from the label."""
    return float(np.mean(np.asarray(learner) != np.asarray(supervisor)))


def run(config: DARTConfig, progress: ProgressCallback | None = None) -> RunResult:
    with Harness("dart", config, progress) as harness:
        space = harness.action_space
        if harness.discrete and config.alpha is not None:
            raise ValueError("DARTConfig: 'alpha' (trace scaling) applies to Box actions only")
        actor = isotropic_actor(space, config.initial_noise_std, config.initial_epsilon)
        heldout_start = 0  # held-out pairs before this index came from an older noise
        noise_level = config.initial_epsilon if harness.discrete else config.initial_noise_std**2

        for iteration in range(1, config.iterations + 1):
            demos = [harness.collect(actor) for _ in range(config.demos_per_iteration)]
            for demo in demos:
                harness.aggregate(demo, heldout_fraction=config.heldout_fraction, keep_heldout=True)
            if iteration in config.update_at:
                policy = harness.fit()
                if len(harness.heldout) == heldout_start:
                    raise ValueError(
                        "DART has no held-out pairs to estimate the noise from: the episodes "
                        f"are not longer than samples_per_demo={config.samples_per_demo}; "
                        "set heldout_fraction (e.g. 0.1) or a smaller samples_per_demo"
                    )
                with harness.training():
                    states, labels = harness.heldout.arrays()
                    states, labels = states[heldout_start:], labels[heldout_start:]
                    predicted = policy.predict(states)
                    if harness.discrete:
                        epsilon = disagreement_probability(predicted, labels)
                        actor = NoisySupervisorActor(space, epsilon=epsilon)
                        noise_level = epsilon
                    else:
                        covariance = disagreement_covariance(predicted, labels)
                        if config.alpha is not None:
                            covariance = scale_to_trace(covariance, config.alpha)
                        actor = NoisySupervisorActor(space, covariance=covariance)
                        noise_level = float(np.trace(covariance))
                heldout_start = len(harness.heldout)
            # noise_level: trace of Sigma (Box) or epsilon (Discrete) used for the next rollouts
            harness.record(iteration, demos, noise_level=noise_level)
        return harness.result()
