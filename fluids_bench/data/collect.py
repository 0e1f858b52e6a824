"""Supervisor-labelled episodes collected in parallel: a local process pool, or Ray.

Every episode is `fluids_bench.algos.rollout.rollout` (the suite's one rollout function)
on `gym.make(env_id, **env_kwargs)`, and returns its `Trajectory`:
the observations, the executed actions, the supervisor's labels of the states they were taken
from, rewards and infos. Who acts is an `ActorSpec`:

* `"supervisor"`: the supervisor itself (the executed action is the label);
* `"noise"`: the supervisor with injected noise: `label + N(0, noise_std² I)` clipped to
  the bounds for Box actions, another action with probability `epsilon` for Discrete ones
  (`fluids_bench.algos.noise.isotropic_actor`); the label stays the supervisor's;
* `"learner"`: a fitted policy acts and the supervisor labels what it visits.

Reproducibility: episode `i` always runs from `reset(seed=seed + i)` and its actor draws
from a generator derived from that seed only, each worker keeps one env per (id, kwargs) and
every episode starts from a full reset, and results come back ordered by episode index. So the
same arguments give identical data whatever the backend and the number of workers.

Batched: with `workers=1`, an id with a vector env (FLUIDS) steps `batch` episodes at a time
on it (`fluids_bench.algos.vector_rollout`), each the trajectory it gets alone.

Backends: `"process"` (default) runs `workers` processes of a
`fluids_bench.core.parallel.process_pool` started with `start_method` (`"forkserver"`,
whose server imports this module once, or `"spawn"`; never `fork`), or in this process when
`workers == 1`; `"ray"` runs one Ray task per episode, at most `workers` at a time (Ray is
the `ray` extra). Both are `fluids_bench.core.parallel.run_tasks`; the actor is sent to
each worker once.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
from tqdm.auto import tqdm

import fluids_bench  # noqa: F401  (registers the suite's env ids in every worker)
from fluids_bench.algos.actors import SUPERVISOR, Actor, LearnerActor
from fluids_bench.algos.dataset import Trajectory
from fluids_bench.algos.noise import isotropic_actor
from fluids_bench.algos.policies import Policy
from fluids_bench.algos.rollout import actor_rng, rollout
from fluids_bench.algos.vector_rollout import (
    DEFAULT_BATCH,
    EpisodeEnd,
    has_vector_env,
    run_vector_episodes,
    trajectory,
)
from fluids_bench.core.parallel import BACKENDS, START_METHODS, run_tasks, worker_env
from fluids_bench.core.splits import refuse_test_seeds
from fluids_bench.core.validation import check_choice, check_float, check_int

PROVENANCES = ("supervisor", "noise", "learner")


@dataclass(frozen=True)
class ActorSpec:
    """Who executes the actions (`kind`, one of `PROVENANCES`) and with which noise."""

    kind: str = "supervisor"
    noise_std: float = 0.0  # "noise", Box actions: std of the Gaussian added to the label
    epsilon: float = 0.0  # "noise", Discrete actions: probability of another action
    policy: Policy | None = field(default=None, compare=False)  # "learner": the acting policy

    def __post_init__(self) -> None:
        check_choice("ActorSpec", "kind", self.kind, PROVENANCES)
        check_float("ActorSpec", "noise_std", self.noise_std, 0.0)
        check_float("ActorSpec", "epsilon", self.epsilon, 0.0, 1.0)
        if (self.kind == "learner") != (self.policy is not None):
            raise ValueError(
                f"ActorSpec: field 'policy' is {self.policy!r}; allowed: a fitted "
                "policy for kind 'learner', None otherwise"
            )

    def build(self, action_space: gym.spaces.Space) -> Actor:
        if self.kind == "noise":
            return isotropic_actor(action_space, self.noise_std, self.epsilon)
        if self.kind == "learner":
            return LearnerActor(self.policy)
        return SUPERVISOR

    def describe(self) -> str:
        if self.kind == "noise":
            return f"noise-injected supervisor (noise_std={self.noise_std}, epsilon={self.epsilon})"
        if self.kind == "learner":
            return f"learner ({type(self.policy).__name__}) labelled by the supervisor"
        return "supervisor"


@dataclass(frozen=True)
class EpisodeTask:
    """Everything one episode depends on but the actor (what a worker receives; the actor is
    the batch's shared payload, sent to each worker once)."""

    index: int
    env_id: str
    env_kwargs: dict[str, Any]
    seed: int
    max_steps: int | None


def run_episode(task: EpisodeTask, actor: ActorSpec) -> tuple[int, Trajectory]:
    """Run one episode (in whichever process receives the task); returns (index, trajectory)."""
    env = worker_env(task.env_id, task.env_kwargs)
    return task.index, rollout(env, actor.build(env.action_space), task.seed, task.max_steps)


def collect(
    env_id: str,
    episodes: int,
    *,
    env_kwargs: dict[str, Any] | None = None,
    actor: ActorSpec | None = None,
    seed: int = 0,
    max_steps: int | None = None,
    workers: int = 1,
    backend: str = "process",
    address: str | None = None,
    start_method: str = "forkserver",
    progress: bool = True,
    skip: Iterable[int] = (),
    on_episode: Callable[[int, Trajectory], None] | None = None,
    batch: int = DEFAULT_BATCH,
) -> list[Trajectory]:
    """Collect `episodes` episodes of `env_id`; episode `i` uses seed `seed + i`.

    `max_steps` cuts episodes short (on top of the env's own time limit). Returns the
    trajectories in episode order. `progress` shows a tqdm bar (episodes and pairs).
    `skip`: indices of episodes not to run (finished by an earlier, interrupted run; they are
    left out of the returned list). `on_episode(i, trajectory)` is called in this process as
    each episode finishes (completion order), e.g. to write it to disk at once.
    `batch`: with `workers=1`, episodes of an id with a vector env (FLUIDS) are stepped
    `batch` at a time on it, each the trajectory it gets alone (infos up to number types:
    numpy scalars where the scalar env gives Python ones); 1: one by one.
    """
    check_int("collect", "episodes", episodes, 1)
    check_int("collect", "seed", seed, 0)
    refuse_test_seeds(range(seed, seed + episodes), "collect")
    check_int("collect", "workers", workers, 1)
    check_int("collect", "batch", batch, 1)
    if max_steps is not None:
        check_int("collect", "max_steps", max_steps, 1)
    check_choice("collect", "backend", backend, BACKENDS)
    check_choice("collect", "start_method", start_method, START_METHODS)
    if env_id not in gym.registry:
        raise ValueError(f"collect: unknown env id {env_id!r}; allowed: {sorted(gym.registry)}")
    actor = actor or ActorSpec()
    kwargs = dict(env_kwargs or {})
    worker_env(env_id, kwargs)  # a bad env argument fails here, once, before any worker starts
    done_before = set(skip)
    todo = [i for i in range(episodes) if i not in done_before]
    tasks = [EpisodeTask(i, env_id, kwargs, seed + i, max_steps) for i in todo]
    results: dict[int, Trajectory] = {}
    bar = tqdm(total=len(todo), desc=f"collect {env_id}", unit="ep", disable=not progress)
    with bar:
        pairs = 0

        def done(task: EpisodeTask, result: tuple[int, Trajectory]) -> None:
            nonlocal pairs
            index, trajectory = result
            results[index] = trajectory
            if on_episode is not None:
                on_episode(index, trajectory)
            pairs += len(trajectory)
            bar.update(1)
            bar.set_postfix(pairs=pairs, refresh=False)

        if (
            len(tasks) > 1
            and backend == "process"
            and workers == 1
            and batch > 1
            and has_vector_env(env_id)
        ):
            _collect_batched(tasks, actor, done, batch)
        else:
            run_tasks(
                run_episode,
                tasks,
                actor,
                done,
                backend=backend,
                workers=workers,
                address=address,
                start_method=start_method,
            )
    return [results[i] for i in todo]


def _collect_batched(
    tasks: list[EpisodeTask],
    spec: ActorSpec,
    done: Callable[[EpisodeTask, tuple[int, Trajectory]], None],
    batch: int,
) -> None:
    """`tasks` in this process, `batch` at a time on their id's vector env: each
    trajectory is `run_episode`'s (infos up to number types), handed to `done` as it ends."""
    first = tasks[0]
    actor = spec.build(worker_env(first.env_id, first.env_kwargs).action_space)

    def act(space, observations, labels, rngs):
        return [actor(o, label, r) for o, label, r in zip(observations, labels, rngs, strict=True)]

    def finished(end: EpisodeEnd) -> None:
        task = tasks[end.index]
        done(task, (task.index, trajectory(end)))

    run_vector_episodes(
        first.env_id, first.env_kwargs, [t.seed for t in tasks], act, actor_rng, finished,
        batch=batch, max_steps=first.max_steps, record=True,
    )  # fmt: skip
