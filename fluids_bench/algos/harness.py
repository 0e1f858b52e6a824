"""The bookkeeping every algorithm shares, so that each algorithm module shows only its loop.

A :class:`Harness` owns the env, the seeds, the aggregate dataset, the label count, the fit
timer and the evaluation protocol of one run:

- seeds: one :class:`numpy.random.SeedSequence` from ``config.seed`` is split into independent
  streams for episode seeds, evaluation seeds, subsampling, the algorithm's own choices and
  model ``random_state``s (one per training-set size, so evaluating more often never changes
  what the algorithm learns);
- evaluation: the learner and (once, up front) the supervisor are rolled out on the same
  ``eval_episodes`` seeds; normalised performance is their ratio after ``return_floor``;
  success and collisions are summarised too where the env reports them
  (:mod:`~fluids_bench.algos.evaluation`);
- compute: ``fit_seconds`` (fitting) and the wall clock of everything but evaluation
  (collection, labelling, fitting), see :class:`~fluids_bench.algos.results.IterationRecord`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

import fluids_bench  # noqa: F401  (registers the suite's env ids)
from fluids_bench.algos.actors import SUPERVISOR, Actor, LearnerActor
from fluids_bench.algos.config import RunConfig
from fluids_bench.algos.dataset import Dataset, Trajectory, split_pairs
from fluids_bench.algos.evaluation import Evaluation, evaluate_trajectories
from fluids_bench.algos.policies import Policy, check_action_space, fit_policy
from fluids_bench.algos.results import IterationRecord, RunResult
from fluids_bench.algos.rollout import rollout
from fluids_bench.core.supervisor import has_supervisor
from fluids_bench.registration import ENV_SPECS

SEED_BOUND = 2**31 - 1
ProgressCallback = Callable[[IterationRecord], None]


def make_env(env_id: str, env_kwargs: dict[str, Any]) -> gym.Env[Any, Any]:
    """``gym.make`` with errors that say which ids exist and what an algorithm needs."""
    if env_id not in gym.registry:
        raise ValueError(
            f"unknown env id {env_id!r}; allowed: the suite's ids {sorted(ENV_SPECS)} "
            "or any other registered Gymnasium id whose env has a supervisor"
        )
    try:
        env = gym.make(env_id, **env_kwargs)
    except ImportError as exc:
        raise ValueError(f"env {env_id!r} cannot be built here: {exc}") from exc
    if not isinstance(env.observation_space, spaces.Box):
        raise ValueError(
            f"env {env_id!r} has observation space {env.observation_space}; "
            "allowed: a Box observation space"
        )
    check_action_space(env.action_space)
    if not has_supervisor(env):  # asked through the wrapper chain, not only the base env
        env.close()
        raise ValueError(
            f"env {env_id!r} has no supervisor_action(); allowed: envs (or wrappers) "
            "implementing fluids_bench.core.supervisor.SupervisedEnv, e.g. any env wrapped in "
            "fluids_bench.core.supervisor.SupervisorWrapper(env, supervisor)"
        )
    return env


class Harness:
    """Env, data, seeds, timing and evaluation of one run of algorithm ``algo``."""

    def __init__(
        self, algo: str, config: RunConfig, progress: ProgressCallback | None = None
    ) -> None:
        self.algo = algo
        self.config = config
        self.progress = progress
        self.env = make_env(config.env_id, dict(config.env_kwargs))
        self.action_space = self.env.action_space
        self.discrete = check_action_space(self.action_space)
        streams = np.random.SeedSequence(config.seed).spawn(5)
        episode_ss, eval_ss, split_ss, model_ss, algo_ss = streams
        self._episode_rng = np.random.default_rng(episode_ss)
        self._split_rng = np.random.default_rng(split_ss)
        # a fit's random_state depends only on the run's seed and the data size, so extra
        # evaluation-only fits never change the random state of the algorithm's own fits
        self._model_word = int(model_ss.generate_state(1)[0])
        # for an algorithm's own random choices (e.g. bagging a committee)
        self.rng = np.random.default_rng(algo_ss)
        self.eval_seeds = [
            int(s)
            for s in np.random.default_rng(eval_ss).integers(SEED_BOUND, size=config.eval_episodes)
        ]
        self.train = Dataset()
        self.heldout = Dataset()
        self.labels_requested = 0
        self.demonstrations = 0
        self.fit_seconds = 0.0
        self.policy: Policy | None = None
        self._policy_pairs = -1  # training-set size the current policy was fit on
        self.records: list[IterationRecord] = []
        self._reports_success = False  # an evaluation episode has ended with info["is_success"]
        supervisor = self.evaluate(SUPERVISOR)
        self.supervisor_return = supervisor.mean_return
        self.supervisor_metrics = supervisor.metrics()
        # wall clock of the algorithm's own work: evaluation time is taken back out
        self._start = time.perf_counter()
        self._excluded_seconds = 0.0

    # -- data --------------------------------------------------------------------------------

    def collect(self, actor: Actor) -> Trajectory:
        """Roll out ``actor`` on the next episode seed."""
        self.demonstrations += 1
        seed = int(self._episode_rng.integers(SEED_BOUND))
        return rollout(self.env, actor, seed, self.config.max_steps)

    def aggregate(
        self,
        trajectory: Trajectory,
        candidates: np.ndarray | None = None,
        *,
        heldout_fraction: float = 0.0,
        keep_heldout: bool = False,
        subsample: bool = True,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Add the supervisor's labels of some visited states to the training set.

        ``candidates`` are the step indices whose labels the algorithm requests (default all);
        they are split by the ch. 3 protocol (:func:`split_pairs`), capped at
        ``samples_per_demo`` unless ``subsample=False`` (SHIV's queried states are all kept).
        Held-out pairs are kept in :attr:`heldout` (and counted) only when ``keep_heldout``.
        Returns the training pairs.
        """
        steps = np.arange(len(trajectory)) if candidates is None else np.asarray(candidates)
        cap = self.config.samples_per_demo if subsample else None
        train, heldout = split_pairs(len(steps), cap, heldout_fraction, self._split_rng)
        observations, labels = trajectory.states[steps[train]], trajectory.labels[steps[train]]
        self.train.add(observations, labels)
        self.labels_requested += len(train)
        if keep_heldout:
            self.heldout.add(trajectory.states[steps[heldout]], trajectory.labels[steps[heldout]])
            self.labels_requested += len(heldout)
        return observations, labels

    # -- learning ----------------------------------------------------------------------------

    @contextmanager
    def training(self) -> Iterator[None]:
        """Count the time spent inside the block as the algorithm's training compute."""
        start = time.perf_counter()
        try:
            yield
        finally:
            self.fit_seconds += time.perf_counter() - start

    def _fit(self) -> tuple[Policy, float]:
        observations, labels = self.train.arrays()
        random_state = int(
            np.random.default_rng([self._model_word, len(self.train)]).integers(SEED_BOUND)
        )
        start = time.perf_counter()
        policy = fit_policy(
            self.config.policy, self.action_space, observations, labels, random_state
        )
        return policy, time.perf_counter() - start

    def fit(self) -> Policy:
        """Fit the learner on all training pairs; the time counts as the algorithm's."""
        policy, seconds = self._fit()
        self.fit_seconds += seconds
        return self.set_policy(policy)

    def set_policy(self, policy: Policy) -> Policy:
        """Declare ``policy`` the learner for all data so far (algorithms that fit their own way)."""
        self.policy = policy
        self._policy_pairs = len(self.train)
        return policy

    def _policy_is_current(self) -> bool:
        return self.policy is not None and self._policy_pairs == len(self.train)

    def evaluate(self, actor: Actor) -> Evaluation:
        """``actor`` over the evaluation seeds: return, success, collisions."""
        episodes = [rollout(self.env, actor, s, self.config.max_steps) for s in self.eval_seeds]
        summary = evaluate_trajectories(episodes, self._reports_success)
        self._reports_success = summary.success_rate is not None
        return summary

    def evaluate_actor(self, actor: Actor) -> float:
        """Mean return of ``actor`` over the evaluation seeds."""
        return self.evaluate(actor).mean_return

    def normalise(self, value: float) -> float | None:
        floor = self.config.return_floor
        if self.supervisor_return <= floor:
            return None  # undefined: the supervisor does not beat the floor on these seeds
        return (value - floor) / (self.supervisor_return - floor)

    # -- records -----------------------------------------------------------------------------

    def record(
        self,
        iteration: int,
        trajectories: Sequence[Trajectory],
        **extras: float,
    ) -> IterationRecord:
        """Log an iteration; evaluate a learner trained on all data when one is due."""
        wall = time.perf_counter() - self._start - self._excluded_seconds
        seconds = self.fit_seconds
        evaluation = normalised = None
        if self.config.evaluates_at(iteration):
            excluded_from = time.perf_counter()
            extra_seconds = 0.0
            if not self._policy_is_current():
                # a fit only the evaluation needs: it counts for this record, not later ones
                self.policy, extra_seconds = self._fit()
                self._policy_pairs = len(self.train)
                seconds += extra_seconds
                wall += extra_seconds
            assert self.policy is not None
            evaluation = self.evaluate(LearnerActor(self.policy))
            normalised = self.normalise(evaluation.mean_return)
            self._excluded_seconds += time.perf_counter() - excluded_from
        record = IterationRecord(
            iteration=iteration,
            demonstrations=self.demonstrations,
            labels_requested=self.labels_requested,
            train_seconds=seconds,
            collection_return=float(np.mean([t.total_return for t in trajectories])),
            eval_return=None if evaluation is None else evaluation.mean_return,
            normalised_performance=normalised,
            extras={k: float(v) for k, v in extras.items()},
            training_labels=len(self.train),
            estimation_labels=len(self.heldout),
            wall_seconds=wall,
        )
        if evaluation is not None:
            record.eval_return_se = evaluation.return_se
            record.eval_success_rate = evaluation.success_rate
            record.eval_success_se = evaluation.success_se
            record.eval_collisions = evaluation.collisions
        self.records.append(record)
        if self.progress is not None:
            self.progress(record)
        return record

    def result(self) -> RunResult:
        """The run's result; ``policy`` is the learner fit on all training data."""
        if not self._policy_is_current():
            self.policy = self._fit()[0]
            self._policy_pairs = len(self.train)
        return RunResult(
            algo=self.algo,
            config=self.config.to_dict(),
            supervisor_return=self.supervisor_return,
            records=self.records,
            supervisor_metrics=self.supervisor_metrics,
            policy=self.policy,
            dataset=self.train,
        )

    def close(self) -> None:
        self.env.close()

    def __enter__(self) -> Harness:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
