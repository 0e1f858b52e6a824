"""SHIV: SVM-based reduction in Human InterVention (ch. 6).

DAgger with stream-based active learning. Before the loop, `initial_demos` supervisor
demonstrations (subsampled by `samples_per_demo` like every demonstration) form `D_0`.
Each iteration:

1. Step 1 (Eq. 9): fit `theta_k = argmin_theta sum_n l(pi_theta(x_n), u_n)` on the aggregate
   data `D_k` (initially the supervisor's demonstrations);
2. fit the risk model on `D_k` and `theta_k` (Eq. 7–8, `ShivSelector`);
3. Step 2: roll out `pi_theta_k` (the learner always acts; the supervisor never takes over)
   and ask the supervisor only about the risky visited states, every one of them (no
   `samples_per_demo` cap: the number queried is SHIV's measure of supervisor burden):
   `D_{k+1} = D_k ∪ {(x_t, u*_t) : g(x_t) = -1}`.

Defaults are the source's: `nu = 0.1`, `nu_r = 1e-3`, `epsilon` = the median L2 training
error (Box actions; 0/1 loss with `epsilon = 0` for Discrete ones). The source tunes
`sigma` and `sigma_r` by a grid search (3 iterations of one trial); the default here,
`sigma=None`, standardises the features and uses the median distance between distinct
training states (`KernelSpace`), and `sigma_r=None` follows
`sigma`. Explicit values are in raw observation units (the source's 200 for HOG features).
A bandwidth far below the typical distance between states makes every new state novel and
SHIV queries what DAgger queries. With a learner that predicts all its training states within
`epsilon` (a deep tree on Discrete labels) the mispredicted set is empty and SHIV reduces to
novelty detection (`selector="novelty"`); the `mispredicted` extra reports `|D_r|`.

`grid_search_bandwidths` is the source's tuning procedure: one trial of SHIV for 3
iterations per candidate `(sigma, sigma_r)`, scored by the learner's surrogate loss on the
states its own policy visits.

The risk model stays fixed during a rollout, so deciding after the rollout is the same as
deciding state by state. `selector` swaps in one of the ch. 6 baselines (novelty only,
confidence, query-by-committee, MMD) to compare query selection methods under one loop.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from gymnasium import spaces

from fluids_bench.algos.actors import SUPERVISOR, LearnerActor
from fluids_bench.algos.config import RunConfig
from fluids_bench.algos.harness import Harness, ProgressCallback, make_env
from fluids_bench.algos.query import (
    SELECTORS,
    CommitteeSelector,
    ConfidenceSelector,
    MMDSelector,
    NoveltySelector,
    QuerySelector,
    ShivSelector,
    check_bandwidths,
    surrogate_loss,
)
from fluids_bench.algos.results import RunResult
from fluids_bench.algos.rollout import rollout
from fluids_bench.core.validation import check_choice, check_float, check_int


@dataclass(frozen=True, kw_only=True)
class SHIVConfig(RunConfig):
    """`(nu, sigma)`: the well-predicted level set; `(nu_r, sigma_r)`: the mispredicted one
    (`sigma=None`: scale-aware bandwidth; `sigma_r=None`: same as `sigma`); `epsilon`:
    allowed L2 error for Box actions (None: the median training error)."""

    selector: str = "shiv"
    nu: float = 0.1
    sigma: float | None = None
    nu_r: float = 1e-3
    sigma_r: float | None = None
    epsilon: float | None = None
    initial_demos: int = 1

    def __post_init__(self) -> None:
        super().__post_init__()
        where = type(self).__name__
        check_choice(where, "selector", self.selector, SELECTORS)
        check_float(where, "nu", self.nu, 0.0, 1.0, lo_open=True)
        if self.sigma is not None:
            check_float(where, "sigma", self.sigma, 0.0, lo_open=True)
        check_float(where, "nu_r", self.nu_r, 0.0, 1.0, lo_open=True)
        if self.sigma_r is not None:
            check_float(where, "sigma_r", self.sigma_r, 0.0, lo_open=True)
        check_bandwidths(where, self.sigma, self.sigma_r)
        if self.epsilon is not None:
            check_float(where, "epsilon", self.epsilon, 0.0)
        check_int(where, "initial_demos", self.initial_demos, 1)


def make_selector(
    config: SHIVConfig, action_space: spaces.Space[Any], rng: np.random.Generator
) -> QuerySelector:
    discrete = isinstance(action_space, spaces.Discrete)
    if config.selector == "shiv":
        return ShivSelector(
            discrete, config.nu, config.sigma, config.nu_r, config.sigma_r, config.epsilon
        )
    if config.selector == "novelty":
        return NoveltySelector(config.nu, config.sigma)
    if config.selector == "confidence":
        return ConfidenceSelector(action_space, rng)
    if config.selector == "qbc":
        return CommitteeSelector(action_space, rng)
    return MMDSelector(config.nu, config.sigma)


def run(config: SHIVConfig, progress: ProgressCallback | None = None) -> RunResult:
    with Harness("shiv", config, progress) as harness:
        selector = make_selector(config, harness.action_space, harness.rng)
        demos = harness.collect_many(SUPERVISOR, config.initial_demos)
        for demo in demos:
            harness.aggregate(demo)
        policy = harness.fit()
        harness.record(0, demos)

        for iteration in range(1, config.iterations + 1):
            with harness.training():  # the risk model is part of SHIV's compute
                selector.fit(*harness.train.arrays(), policy)
            rollouts = harness.collect_many(LearnerActor(policy), config.demos_per_iteration)
            visited = queried = 0
            for trajectory in rollouts:
                risky = np.flatnonzero(selector.risky(trajectory.states))
                queried += len(harness.aggregate(trajectory, risky, subsample=False)[0])
                visited += len(trajectory)
            policy = harness.fit()
            extras = {"queried": queried, "visited": visited}
            if isinstance(selector, ShivSelector):
                # the risk model this iteration's queries came from
                extras.update(
                    mispredicted=selector.mispredicted,
                    sigma=selector.sigma,
                    sigma_r=selector.sigma_r,
                )
            harness.record(iteration, rollouts, **extras)
        return harness.result()


@dataclass(frozen=True)
class BandwidthTrial:
    sigma: float
    sigma_r: float
    surrogate_loss: float  # mean loss of the final learner on states its own policy visits
    labels: int  # labels SHIV asked for in the trial


def grid_search_bandwidths(
    config: SHIVConfig,
    sigmas: Sequence[float],
    sigma_rs: Sequence[float] | None = None,
    iterations: int = 3,
    episodes: int = 5,
) -> tuple[SHIVConfig, list[BandwidthTrial]]:
    """The source's choice of `sigma` and `sigma_r` (ch. 6): a grid search "on the surrogate
    loss for a single trial of SHIV for 3 iterations".

    Every pair of `sigmas` x `sigma_rs` (raw units; `sigma_rs=None` pairs each sigma with
    itself) runs SHIV from `config` for `iterations` iterations (same seed, so the same
    initial demonstrations); its final learner is rolled out for `episodes` episodes and
    scored by its surrogate loss against the supervisor's labels of the states it visited.
    Returns `config` with the lowest-loss pair (ties: fewer labels, then the larger sigma)
    and every trial.
    """
    if not sigmas:
        raise ValueError("grid_search_bandwidths: 'sigmas' is empty; allowed: bandwidths > 0")
    pairs = (
        [(s, s) for s in sigmas] if sigma_rs is None else [(s, r) for s in sigmas for r in sigma_rs]
    )
    env = make_env(config.env_id, dict(config.env_kwargs))
    discrete = isinstance(env.action_space, spaces.Discrete)
    seeds = [
        int(x)
        for x in np.random.default_rng([config.seed, 0x5161]).integers(2**31 - 1, size=episodes)
    ]
    trials = []
    try:
        for sigma, sigma_r in pairs:
            trial = replace(
                config,
                sigma=float(sigma),
                sigma_r=float(sigma_r),
                iterations=iterations,
                eval_at=(),
                checkpoint=None,  # trials are short, and each is a run of its own
            )
            result = run(trial)
            visited = [
                rollout(env, LearnerActor(result.policy), s, config.max_steps) for s in seeds
            ]
            states = np.concatenate([t.states for t in visited])
            labels = np.concatenate([t.labels for t in visited])
            loss = surrogate_loss(result.policy.predict(states), labels, discrete)
            trials.append(
                BandwidthTrial(
                    float(sigma), float(sigma_r), float(loss.mean()), result.final.labels_requested
                )
            )
    finally:
        env.close()
    best = min(trials, key=lambda t: (t.surrogate_loss, t.labels, -t.sigma))
    return replace(config, sigma=best.sigma, sigma_r=best.sigma_r), trials
