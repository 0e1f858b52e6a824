"""The bookkeeping every algorithm shares, so that each algorithm module shows only its loop.

A `Harness` owns the env, the seeds, the aggregate dataset, the label count, the fit
timer and the evaluation protocol of one run:

- seeds: one `numpy.random.SeedSequence` from `config.seed` is split into independent
  streams for episode seeds, evaluation seeds, subsampling, the algorithm's own choices and
  model `random_state`s (one per training-set size, so evaluating more often never changes
  what the algorithm learns);
- evaluation: the learner and (once, up front) the supervisor are rolled out on the same
  `eval_episodes` seeds; normalised performance is their ratio after `return_floor`;
  success and collisions are summarised too where the env reports them
  (`evaluation`). Without workers, on an id with a vector env (FLUIDS), the episodes are
  stepped `EVAL_BATCH` at a time (`vector_rollout`), with the same summary; so are the
  rollouts an algorithm asks for together (the same trajectories, infos up to number types);
- compute: `fit_seconds` (fitting) and the wall clock of everything but evaluation
  (collection, labelling, fitting), see `IterationRecord`;
- execution: the rollouts an algorithm asks for together (`Harness.collect_many`, an
  iteration's demonstrations) and the evaluation episodes run on `config.workers` processes
  or Ray tasks (`fluids_bench.core.parallel.TaskSession`, opened once per run); their
  seeds are drawn in order in this process before they start and the results are put back in
  that order, so the records are the same whatever the workers and the backend. The learner is
  fitted here, once per iteration;
- learners: `config.policy` a `PolicySpec` is fit afresh with a seeded `random_state`;
  a user's learner (`fluids_bench.algos.learners`) is built once per run and refit in
  place by every fit, including a fit only an evaluation needs: with a warm-starting learner
  (the torch ones) later fits continue from it, so there the evaluation schedule is part of
  what is learned;
- resuming: with `config.checkpoint`, every finished rollout, evaluation and record is kept
  on disk and a rerun takes them from there (`checkpoint`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

import fluids_bench  # noqa: F401  (registers the suite's env ids)
from fluids_bench.algos.actors import SUPERVISOR, Actor, LearnerActor, stateless
from fluids_bench.algos.checkpoint import Checkpoint
from fluids_bench.algos.config import RunConfig
from fluids_bench.algos.dataset import Dataset, Trajectory, split_pairs
from fluids_bench.algos.evaluation import Evaluation, evaluate_trajectories, summarise
from fluids_bench.algos.learners.protocol import (
    Learner,
    LearnerPolicy,
    Policy,
    check_action_space,
    make_learner,
)
from fluids_bench.algos.learners.sklearn import PolicySpec, fit_policy
from fluids_bench.algos.results import IterationRecord, RunResult
from fluids_bench.algos.rollout import actor_rng, rollout
from fluids_bench.algos.vector_rollout import (
    EpisodeEnd,
    has_vector_env,
    run_vector_episodes,
    trajectory,
)
from fluids_bench.core.parallel import TaskSession, worker_env
from fluids_bench.core.splits import refuse_test_seeds
from fluids_bench.core.supervisor import has_supervisor
from fluids_bench.registration import ENV_SPECS

SEED_BOUND = 2**31 - 1
ProgressCallback = Callable[[IterationRecord], None]
TIMING_FIELDS = ("train_seconds", "wall_seconds")  # the only fields that differ between reruns
# evaluation episodes stepped together on the id's vector env (FLUIDS) when the run has no
# workers; 1: one by one
EVAL_BATCH = 32


@dataclass(frozen=True)
class RolloutTask:
    """One rollout as a worker receives it; the actor is the batch's shared payload."""

    index: int  # position in the batch
    env_id: str
    env_kwargs: dict[str, Any]
    seed: int
    max_steps: int | None


def run_rollout(task: RolloutTask, actor: Actor) -> Trajectory:
    """A rollout in a worker process, on that worker's env for the id and kwargs (kept across
    tasks: every rollout starts from a full reset)."""
    return rollout(worker_env(task.env_id, task.env_kwargs), actor, task.seed, task.max_steps)


def make_env(env_id: str, env_kwargs: dict[str, Any]) -> gym.Env[Any, Any]:
    """`gym.make` with errors that say which ids exist and what an algorithm needs."""
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
    """Env, data, seeds, timing and evaluation of one run of algorithm `algo`."""

    def __init__(
        self, algo: str, config: RunConfig, progress: ProgressCallback | None = None
    ) -> None:
        self.algo = algo
        self.config = config
        self.progress = progress
        self._resources = contextlib.ExitStack()
        try:
            self._setup()
        except BaseException as exc:
            self._resources.__exit__(type(exc), exc, exc.__traceback__)
            raise

    def _setup(self) -> None:
        config = self.config
        self.env = make_env(config.env_id, dict(config.env_kwargs))
        self._resources.callback(self.env.close)
        self.store = (
            None if config.checkpoint is None else Checkpoint(config.checkpoint, self.algo, config)
        )
        # the fork server imports the rollout's modules once, before starting the workers
        preload = (__name__,)
        self._session = self._resources.enter_context(
            TaskSession(config.backend, config.workers, config.address, preload=preload)
        )
        self._evaluations = 0  # evaluations so far (0: the supervisor's)
        self._timing_offset = {name: 0.0 for name in TIMING_FIELDS}  # saved minus recomputed
        self.action_space = self.env.action_space
        self.discrete = check_action_space(self.action_space)
        # a user's learner (config.policy is not a PolicySpec): built once per run, told the
        # env's spaces when it asks for them, and refit in place by every fit
        self.learner: Learner | None = None
        if not isinstance(config.policy, PolicySpec):
            self.learner = make_learner(config.policy, f"{type(config).__name__}.policy")
            set_spaces = getattr(self.learner, "set_spaces", None)
            if callable(set_spaces):
                set_spaces(self.env.observation_space, self.action_space)
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
        """Roll out `actor` on the next episode seed."""
        return self.collect_many(actor, 1)[0]

    def collect_many(self, actor: Actor, count: int) -> list[Trajectory]:
        """Roll out `actor` on the next `count` episode seeds, in parallel where the run
        has workers; the trajectories come back in seed order."""
        seeds = [int(self._episode_rng.integers(SEED_BOUND)) for _ in range(count)]
        first = self.demonstrations
        self.demonstrations += count
        names = [f"rollout-{first + i:06d}" for i in range(count)]
        return self._rollouts(actor, seeds, names)

    def _rollouts(
        self, actor: Actor, seeds: list[int], names: list[str] | None = None
    ) -> list[Trajectory]:
        """`actor` on each of `seeds`; with `names`, each finished rollout is kept in the
        checkpoint under its name (and taken from there when it is already)."""
        refuse_test_seeds(seeds, "the algorithm harness")  # training never sees a test seed
        results: list[Trajectory | None] = [None] * len(seeds)
        store = self.store if names is not None else None
        if store is not None:
            for i, name in enumerate(names):
                saved = store.load(name)
                if saved is not None and saved.seed != seeds[i]:
                    raise ValueError(
                        f"checkpoint {store.folder}: {name} was rolled out with seed "
                        f"{saved.seed}, this run draws {seeds[i]}; the folder belongs to "
                        "another run: delete it or choose another"
                    )
                results[i] = saved

        def done(task: RolloutTask, trajectory: Trajectory) -> None:
            results[task.index] = trajectory
            if store is not None:
                store.save(names[task.index], trajectory)

        tasks = [
            RolloutTask(
                i, self.config.env_id, dict(self.config.env_kwargs), s, self.config.max_steps
            )
            for i, s in enumerate(seeds)
            if results[i] is None
        ]
        if len(tasks) > 1 and self._session.local and self._batched(actor):  # B at a time
            by_index = {task.index: task for task in tasks}

            def finished(end: EpisodeEnd) -> None:
                done(by_index[end.index], trajectory(end))

            order = [task.index for task in tasks]
            run_vector_episodes(
                self.config.env_id, dict(self.config.env_kwargs), [seeds[i] for i in order],
                self._batch_actor(actor), actor_rng,
                lambda end: finished(dataclasses.replace(end, index=order[end.index])),
                batch=EVAL_BATCH, max_steps=self.config.max_steps, record=True,
            )  # fmt: skip
        elif self._session.local:  # in this process, on the harness's own env
            for task in tasks:
                done(task, rollout(self.env, actor, task.seed, task.max_steps))
        else:
            self._session.run(run_rollout, tasks, actor, done)
        return results  # type: ignore[return-value]  # every slot is filled

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

        `candidates` are the step indices whose labels the algorithm requests (default all);
        they are split by the ch. 3 protocol (`split_pairs`), capped at
        `samples_per_demo` unless `subsample=False` (SHIV's queried states are all kept).
        Held-out pairs are kept in `heldout` (and counted) only when `keep_heldout`.
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
        if self.learner is not None:
            self.learner.fit(observations, labels)
            policy: Policy = LearnerPolicy(self.learner, self.action_space)
        else:
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
        """Declare `policy` the learner for all data so far (algorithms that fit their own way)."""
        self.policy = policy
        self._policy_pairs = len(self.train)
        return policy

    def _policy_is_current(self) -> bool:
        return self.policy is not None and self._policy_pairs == len(self.train)

    def evaluate(self, actor: Actor) -> Evaluation:
        """`actor` over the evaluation seeds: return, success, collisions."""
        name = f"eval-{self._evaluations:04d}"
        self._evaluations += 1
        summary = None if self.store is None else self.store.load(name)
        if summary is None:
            if len(self.eval_seeds) > 1 and self._batched(actor):
                summary = self._evaluate_batched(actor)
            else:
                episodes = self._rollouts(actor, self.eval_seeds)
                summary = evaluate_trajectories(episodes, self._reports_success)
            if self.store is not None:
                self.store.save(name, summary)
        self._reports_success = summary.success_rate is not None
        return summary

    def _batched(self, actor: Actor) -> bool:
        """Whether the rollouts of `actor` step together on the id's vector env: in this
        process (no workers), an id with one, `EVAL_BATCH` > 1, and one of the project's
        actors (each a function of the observation, the label and the episode's generator,
        with no state between steps)."""
        return (
            self._session.local
            and EVAL_BATCH > 1
            and stateless(actor)
            and has_vector_env(self.config.env_id)
        )

    @staticmethod
    def _batch_actor(actor: Actor):
        def act(space, observations, labels, rngs):
            return [
                actor(o, label, r) for o, label, r in zip(observations, labels, rngs, strict=True)
            ]

        return act

    def _evaluate_batched(self, actor: Actor) -> Evaluation:
        """`actor` over the evaluation seeds, `EVAL_BATCH` episodes at a time on the vector
        env: the same summary as `evaluate_trajectories` of their rollouts (tested)."""
        seeds = self.eval_seeds
        refuse_test_seeds(seeds, "the algorithm harness")
        ends: list[EpisodeEnd | None] = [None] * len(seeds)

        def keep(end: EpisodeEnd) -> None:
            ends[end.index] = end

        def act(space, observations, labels, rngs):
            return [
                actor(o, label, r) for o, label, r in zip(observations, labels, rngs, strict=True)
            ]

        run_vector_episodes(
            self.config.env_id, dict(self.config.env_kwargs), seeds, act, actor_rng, keep,
            batch=EVAL_BATCH, max_steps=self.config.max_steps,
        )  # fmt: skip
        done = [e for e in ends if e is not None]
        counted = [e.collisions for e in done]
        return summarise(
            [float(np.sum(np.asarray(e.rewards, dtype=np.float64))) for e in done],
            [e.info for e in done],
            None if all(c is None for c in counted) else [c or 0 for c in counted],
            self._reports_success,
        )

    def evaluate_actor(self, actor: Actor) -> float:
        """Mean return of `actor` over the evaluation seeds."""
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
        if self.store is not None:
            self._keep(record)
        self.records.append(record)
        if self.progress is not None:
            self.progress(record)
        return record

    def _keep(self, record: IterationRecord) -> None:
        """Save `record` in the checkpoint, or, when a finished run saved this iteration,
        check that it is the same and keep the saved timing (the work it measured was done
        then); later records' cumulative times continue from it."""
        assert self.store is not None
        name = f"record-{record.iteration:04d}"
        for field in TIMING_FIELDS:
            setattr(record, field, getattr(record, field) + self._timing_offset[field])
        saved = self.store.load(name)
        if saved is None:
            self.store.save(name, record)
            return
        now, then = dataclasses.asdict(record), dataclasses.asdict(saved)
        for field in TIMING_FIELDS:
            self._timing_offset[field] += then.pop(field) - now.pop(field)
            setattr(record, field, getattr(saved, field))
        if now != then:
            different = sorted(k for k in now if now[k] != then[k])
            raise ValueError(
                f"checkpoint {self.store.folder}: iteration {record.iteration} computes "
                f"{', '.join(different)} other than the saved run did; it cannot be continued "
                "(another install or machine?): delete the folder to start again"
            )

    def result(self) -> RunResult:
        """The run's result; `policy` is the learner fit on all training data."""
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
        self._resources.close()

    def __enter__(self) -> Harness:
        return self

    def __exit__(self, *exc_info: Any) -> None:
        # the exception, if any, reaches the workers' pool: it stops them at once (Ctrl-C)
        # instead of waiting for what is queued
        self._resources.__exit__(*exc_info)
