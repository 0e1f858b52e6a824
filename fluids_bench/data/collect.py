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

Backends: `"process"` (default) runs `workers` processes of a
`ProcessPoolExecutor` started with `start_method`
(`"forkserver"`, whose server imports this module once, or `"spawn"`; never `fork`, and
everything sent to workers pickles by reference or by value), or in this process when
`workers == 1`. `"ray"` runs one Ray task per episode, at most `workers` at
a time, on the Ray instance already initialised, else on the cluster at `address`, else on a
local instance it starts (and stops) with `workers` CPUs; Ray is the `ray` extra.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, wait
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
from tqdm.auto import tqdm

import fluids_bench  # noqa: F401  (registers the suite's env ids in every worker)
from fluids_bench.algos.actors import SUPERVISOR, Actor, LearnerActor
from fluids_bench.algos.dataset import Trajectory
from fluids_bench.algos.noise import isotropic_actor
from fluids_bench.algos.policies import Policy
from fluids_bench.algos.rollout import rollout
from fluids_bench.core.pool import process_pool
from fluids_bench.core.validation import check_choice, check_float, check_int

PROVENANCES = ("supervisor", "noise", "learner")
BACKENDS = ("process", "ray")
START_METHODS = ("spawn", "forkserver")
RAY_MISSING = 'backend="ray" needs Ray: pip install "fluids-bench[ray]"'


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
    """Everything one episode depends on (what a worker receives)."""

    index: int
    env_id: str
    env_kwargs: dict[str, Any]
    actor: ActorSpec
    seed: int
    max_steps: int | None


# one env per (id, kwargs) in each worker process, reused across its episodes
_ENVS: dict[tuple[str, str], gym.Env] = {}


def _env(env_id: str, env_kwargs: dict[str, Any]) -> gym.Env:
    key = (env_id, json.dumps(env_kwargs, sort_keys=True, default=repr))
    if key not in _ENVS:
        _ENVS[key] = gym.make(env_id, **env_kwargs)
    return _ENVS[key]


def run_episode(task: EpisodeTask) -> tuple[int, Trajectory]:
    """Run one episode (in whichever process receives the task); returns (index, trajectory)."""
    env = _env(task.env_id, task.env_kwargs)
    actor = task.actor.build(env.action_space)
    return task.index, rollout(env, actor, task.seed, task.max_steps)


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
) -> list[Trajectory]:
    """Collect `episodes` episodes of `env_id`; episode `i` uses seed `seed + i`.

    `max_steps` cuts episodes short (on top of the env's own time limit). Returns the
    trajectories in episode order. `progress` shows a tqdm bar (episodes and pairs).
    """
    check_int("collect", "episodes", episodes, 1)
    check_int("collect", "seed", seed, 0)
    check_int("collect", "workers", workers, 1)
    if max_steps is not None:
        check_int("collect", "max_steps", max_steps, 1)
    check_choice("collect", "backend", backend, BACKENDS)
    check_choice("collect", "start_method", start_method, START_METHODS)
    if env_id not in gym.registry:
        raise ValueError(f"collect: unknown env id {env_id!r}; allowed: {sorted(gym.registry)}")
    actor = actor or ActorSpec()
    kwargs = dict(env_kwargs or {})
    _env(env_id, kwargs)  # a bad env argument fails here, once, before any worker starts
    tasks = [EpisodeTask(i, env_id, kwargs, actor, seed + i, max_steps) for i in range(episodes)]
    results: dict[int, Trajectory] = {}
    with tqdm(total=episodes, desc=f"collect {env_id}", unit="ep", disable=not progress) as bar:
        pairs = 0

        def done(index: int, trajectory: Trajectory) -> None:
            nonlocal pairs
            results[index] = trajectory
            pairs += len(trajectory)
            bar.update(1)
            bar.set_postfix(pairs=pairs, refresh=False)

        if backend == "ray":
            _run_ray(tasks, workers, address, done)
        elif workers == 1:
            for task in tasks:
                done(*run_episode(task))
        else:
            _run_pool(tasks, workers, start_method, done)
    return [results[i] for i in range(episodes)]


def _bounded(
    submit: Callable[[EpisodeTask], Any],
    tasks: Iterable[EpisodeTask],
    limit: int,
    wait_any: Callable[[set], tuple[set, set]],
) -> Iterator[Any]:
    """Keep at most `limit` tasks in flight; yield each finished handle."""
    pending: set = set()
    for task in tasks:
        if len(pending) >= limit:
            finished, pending = wait_any(pending)
            yield from finished
        pending.add(submit(task))
    while pending:
        finished, pending = wait_any(pending)
        yield from finished


def _run_pool(
    tasks: list[EpisodeTask],
    workers: int,
    start_method: str,
    done: Callable[[int, Trajectory], None],
) -> None:
    # the fork server imports the heavy modules once; workers exit with this process (core.pool)
    with process_pool(workers, start_method, [__name__]) as pool:

        def wait_any(pending: set) -> tuple[set, set]:
            finished, rest = wait(pending, return_when=FIRST_COMPLETED)
            return set(finished), set(rest)

        for future in _bounded(lambda t: pool.submit(run_episode, t), tasks, 2 * workers, wait_any):
            done(*future.result())


def import_ray():
    """`ray`, or an ImportError naming the extra that installs it."""
    try:
        import ray
    except ImportError as exc:
        raise ImportError(RAY_MISSING) from exc
    return ray


@contextlib.contextmanager
def ray_session(workers: int, address: str | None):
    """Ray, initialised for this block (a cluster at `address`, else a local instance of
    `workers` CPUs) unless it already was; shut down after if this block started it."""
    ray = import_ray()
    started = not ray.is_initialized()
    if started:
        if address is not None:
            ray.init(address=address)
        else:
            ray.init(num_cpus=workers, include_dashboard=False)
    try:
        yield ray
    finally:
        if started:
            ray.shutdown()


def ray_results(ray, submit: Callable[[Any], Any], tasks, workers: int):
    """Results of `submit(task)` remote calls, at most `workers` in flight, as they finish."""

    def wait_any(pending: set) -> tuple[set, set]:
        finished, rest = ray.wait(list(pending), num_returns=1)
        return set(finished), set(rest)

    for ref in _bounded(submit, tasks, workers, wait_any):
        yield ray.get(ref)


def _run_ray(
    tasks: list[EpisodeTask],
    workers: int,
    address: str | None,
    done: Callable[[int, Trajectory], None],
) -> None:
    with ray_session(workers, address) as ray:
        remote = ray.remote(num_cpus=1)(run_episode)
        for result in ray_results(ray, remote.remote, tasks, workers):
            done(*result)
