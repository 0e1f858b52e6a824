"""Evaluate one policy over every configuration of a :class:`~fluids_bench.sweep.grid.Grid`.

Configuration ``i`` runs ``episodes`` episodes of ``FLUIDS-Sensitivity-v0`` (velocity actions,
quasi-LIDAR observations, ``done_when="all"``; ``env_id="FLUIDS-Sensitivity-v1"`` for the fair
benchmark's version: defensive background drivers, quasi-LIDAR v1, success also requires that
the ego obeys red lights) with the grid's keyword arguments, each through
:func:`fluids_bench.algos.rollout.rollout` with the learner acting. Success is the source's:
every car reached its goal and nothing collided (``info["is_success"]``); a terminated episode
without success ended in a collision, a truncated one ran out of time.

Episode seeds come from ``SeedSequence(seed, spawn_key=(i,))``: they depend on the sweep seed
and the configuration's index only, so results do not depend on the backend, the number of
workers or on how often the sweep was interrupted and resumed.
"""

from __future__ import annotations

import hashlib
import json
import pickle
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the env ids in every worker)
from fluids_bench.algos.actors import SUPERVISOR, Actor, LearnerActor
from fluids_bench.algos.results import write_bytes_atomic, write_json_atomic
from fluids_bench.algos.rollout import rollout
from fluids_bench.sweep.backends import run_tasks
from fluids_bench.sweep.grid import Grid, env_kwargs
from fluids_bench.sweep.store import ResultStore

ENV_ID = "FLUIDS-Sensitivity-v0"  # the default (the source's setting)
ENV_IDS = ("FLUIDS-Sensitivity-v0", "FLUIDS-Sensitivity-v1")
CHECK_SEED = 900_000  # seeds of the in-distribution check of a trained policy (not training's)
# 40 s of simulated time instead of the registered 600 steps. With the supervisor acting, every
# (cars, pedestrians, lights, mass) cell of the default grid, 5 episodes each, gave the same
# outcomes under 400 and 600 steps (316 of 320 successes; the 3 timeouts are gridlocks without
# lights that last past 600 too): the cap cuts only episodes that fail anyway, which are a
# third of a learner sweep's steps.
MAX_EPISODE_STEPS = 400
SUPERVISOR_POLICY = "supervisor"  # --policy value: the supervisor itself acts (a reference)
POLICY_FILE = "policy.pkl"


@dataclass(frozen=True)
class ConfigTask:
    """Everything configuration ``index`` depends on (what a worker receives)."""

    index: int
    configuration: dict[str, Any]
    env_id: str
    max_episode_steps: int
    seeds: tuple[int, ...]


def episode_seeds(seed: int, index: int, episodes: int) -> tuple[int, ...]:
    """The reset seeds of configuration ``index``'s episodes."""
    state = np.random.SeedSequence(seed, spawn_key=(index,)).generate_state(episodes, np.uint32)
    return tuple(int(s) for s in state)


def evaluate_config(task: ConfigTask, policy: Any) -> dict[str, Any]:
    """Run one configuration's episodes; its result row. ``cpu_seconds`` (this process's CPU
    time for it) is reported but not stored: stored rows must reproduce exactly."""
    cpu_start = time.process_time()
    env = gym.make(
        task.env_id, max_episode_steps=task.max_episode_steps, **env_kwargs(task.configuration)
    )
    actor: Actor = SUPERVISOR if policy is None else LearnerActor(policy)
    successes = collisions = timeouts = steps = 0
    try:
        for seed in task.seeds:
            trajectory = rollout(env, actor, seed)
            success = bool(trajectory.infos[-1].get("is_success", False))
            successes += success
            collisions += trajectory.terminated and not success
            timeouts += trajectory.truncated
            steps += len(trajectory)
    finally:
        env.close()
    episodes = len(task.seeds)
    return {
        "index": task.index,
        **task.configuration,
        "episodes": episodes,
        "successes": successes,
        "collisions": collisions,
        "timeouts": timeouts,
        "success_rate": successes / episodes,
        "mean_steps": steps / episodes,
        "cpu_seconds": time.process_time() - cpu_start,
    }


def check_env_id(env_id: str) -> str:
    if env_id not in ENV_IDS:
        raise ValueError(f"sweep: field 'env' is {env_id!r}; allowed: {list(ENV_IDS)}")
    return env_id


def probe_env(grid: Grid, env_id: str = ENV_ID) -> None:
    """Build and reset the env at the grid's largest and smallest configurations (fail early)."""
    check_env_id(env_id)
    for pick in (0, -1):
        configuration = {name: values[pick] for name, values in grid.values.items()}
        try:
            env = gym.make(env_id, **env_kwargs(configuration))
            env.reset(seed=0)
            env.close()
        except ValueError as exc:
            raise ValueError(f"grid configuration {configuration} is not valid: {exc}") from exc


# -- the policy under evaluation ----------------------------------------------------------------


def policy_digest(policy_bytes: bytes | None) -> str:
    return SUPERVISOR_POLICY if policy_bytes is None else hashlib.sha256(policy_bytes).hexdigest()


def load_policy(path: str | Path) -> tuple[Any, bytes]:
    """A pickled policy (anything with ``act(observation)``) and its bytes. Pickles run code:
    load only files you made."""
    data = Path(path).read_bytes()
    policy = pickle.loads(data)
    if not callable(getattr(policy, "act", None)):
        raise ValueError(
            f"{path}: unpickled a {type(policy).__name__}; allowed: a policy with act(observation)"
        )
    return policy, data


def train_default_policy(
    folder: Path,
    *,
    demos: int = 100,
    learner: str = "tree",
    seed: int = 0,
    replace: bool = False,
    progress: Callable[[Any], None] | None = None,
    before_training: Callable[[], None] | None = None,
    env_id: str = ENV_ID,
    check_episodes: int = 0,
    train_kwargs: Mapping[str, Any] | None = None,
) -> Path:
    """Behavior Cloning on ``demos`` supervisor demonstrations of ``env_id`` (its defaults: 4
    cars, 2 pedestrians, lights on, no sensor noise, 1500 kg), quasi-LIDAR to target velocity,
    every state–label pair kept. Cached in ``folder/policy.pkl`` with the training settings in
    ``policy.json``; an existing cache made with the same settings is reused; one made with
    other settings is replaced only when ``replace``. ``before_training`` is called only when
    training is needed, before it starts (a place to refuse early).

    ``check_episodes``: also run the trained policy on that many seeded episodes of the
    training distribution itself (seeds ``CHECK_SEED + i``, never trained on) and record its
    in-distribution success rate in ``policy.json`` (``in_distribution``). ``train_kwargs``:
    env keyword arguments for the demonstrations (e.g. ``{"lidar_noise": 1.0}``, an ablation:
    BC trained on what it will be tested on); the check then runs under them too."""
    from fluids_bench.algos.bc import BCConfig, run
    from fluids_bench.algos.policies import PolicySpec

    path, info_path = folder / POLICY_FILE, folder / "policy.json"
    train_kwargs = dict(train_kwargs or {})
    config = BCConfig(
        env_id=check_env_id(env_id),
        env_kwargs=train_kwargs,
        policy=PolicySpec(learner),
        iterations=1,
        demos_per_iteration=demos,
        samples_per_demo=None,
        eval_episodes=1,
        seed=seed,
    )
    settings = json.loads(json.dumps({"algo": "bc", "config": config.to_dict()}))
    if path.exists() and info_path.exists():
        info = json.loads(info_path.read_text())
        if info.get("settings") == settings:
            if check_episodes and info.get("in_distribution", {}).get("episodes") != check_episodes:
                policy, _ = load_policy(path)
                info["in_distribution"] = in_distribution_check(
                    env_id, policy, check_episodes, train_kwargs
                )
                write_json_atomic(info_path, info)
            return path
        if not replace:
            raise FileExistsError(
                f"{path} was trained with other settings; use another --out folder, "
                "or --overwrite to retrain it and discard the folder's results"
            )
    if before_training is not None:
        before_training()
    result = run(config, progress)
    record = result.records[-1]
    info = {
        "settings": settings,
        "training_pairs": record.labels_requested,
        "fit_seconds": record.train_seconds,
        "eval_return": record.eval_return,
        "supervisor_return": result.supervisor_return,
    }
    if check_episodes:
        info["in_distribution"] = in_distribution_check(
            env_id, result.policy, check_episodes, train_kwargs
        )
    write_json_atomic(info_path, info)
    # the policy last: a cache is complete only once both files are there
    write_bytes_atomic(path, pickle.dumps(result.policy, protocol=pickle.HIGHEST_PROTOCOL))
    return path


def in_distribution_check(
    env_id: str, policy: Any, episodes: int, env_kwargs: Mapping[str, Any] | None = None
) -> dict[str, Any]:
    """Success of ``policy`` (None: the supervisor) on ``episodes`` seeded episodes of
    ``env_id`` with its registered defaults and ``env_kwargs`` (the distribution BC trains on)."""
    env = gym.make(env_id, max_episode_steps=MAX_EPISODE_STEPS, **dict(env_kwargs or {}))
    actor: Actor = SUPERVISOR if policy is None else LearnerActor(policy)
    successes = collisions = timeouts = 0
    try:
        for i in range(episodes):
            trajectory = rollout(env, actor, CHECK_SEED + i)
            success = bool(trajectory.infos[-1].get("is_success", False))
            successes += success
            collisions += trajectory.terminated and not success
            timeouts += trajectory.truncated
    finally:
        env.close()
    return {
        "episodes": episodes,
        "successes": successes,
        "collisions": collisions,
        "timeouts": timeouts,
        "success_rate": successes / episodes,
    }


# -- the sweep ------------------------------------------------------------------------------


def manifest(
    grid: Grid,
    episodes: int,
    seed: int,
    max_episode_steps: int,
    policy_bytes: bytes | None,
    env_id: str = ENV_ID,
) -> dict[str, Any]:
    """What a sweep's rows depend on (the store refuses to resume under another manifest)."""
    return {
        "format": 1,
        "env_id": env_id,
        "grid": grid.to_dict(),
        "episodes": episodes,
        "seed": seed,
        "max_episode_steps": max_episode_steps,
        "policy_sha256": policy_digest(policy_bytes),
    }


def check_folder_for_new_policy(
    folder: str | Path,
    grid: Grid,
    episodes: int,
    seed: int,
    max_episode_steps: int,
    env_id: str = ENV_ID,
) -> None:
    """Refuse, before a new policy is trained, a folder that already holds a sweep: its rows were
    made with another policy (a cached default policy would have been reused), and maybe with
    other settings too. ``FileExistsError`` names what differs."""
    existing = ResultStore(folder).read_manifest()
    if existing is None:
        return
    wanted = manifest(grid, episodes, seed, max_episode_steps, None, env_id)
    changed = sorted(
        k
        for k in wanted.keys() | existing.keys()
        if k != "policy_sha256" and wanted.get(k) != existing.get(k)
    )
    raise FileExistsError(
        f"{folder} holds a sweep with other settings ({', '.join([*changed, 'policy'])}); "
        "use another --out folder, or --overwrite to discard its results"
    )


def run_sweep(
    folder: str | Path,
    grid: Grid,
    policy: Any,
    policy_bytes: bytes | None,
    *,
    episodes: int = 20,
    seed: int = 0,
    max_episode_steps: int = MAX_EPISODE_STEPS,
    backend: str = "process",
    workers: int = 1,
    address: str | None = None,
    overwrite: bool = False,
    on_start: Callable[[int, int], None] | None = None,
    on_row: Callable[[Mapping[str, Any]], None] | None = None,
    env_id: str = ENV_ID,
) -> list[dict[str, Any]]:
    """Evaluate ``policy`` (None: the supervisor) on every configuration of ``env_id`` not yet
    in ``folder``.

    ``on_start(done, total)`` is called once the finished rows are known, ``on_row(row)`` after
    each new row is stored. Returns all rows, sorted by configuration index.
    """
    with ResultStore(folder) as store:
        done = store.open(
            manifest(grid, episodes, seed, max_episode_steps, policy_bytes, check_env_id(env_id)),
            overwrite,
        )
        if on_start is not None:
            on_start(len(done), len(grid))
        tasks = (
            ConfigTask(
                index, config, env_id, max_episode_steps, episode_seeds(seed, index, episodes)
            )
            for index, config in grid.configurations()
            if index not in done
        )

        def finished(task: ConfigTask, row: dict[str, Any]) -> None:
            store.append(row)
            if on_row is not None:
                on_row(row)

        run_tasks(
            evaluate_config,
            tasks,
            policy,
            finished,
            backend=backend,
            workers=workers,
            address=address,
        )
        return store.sorted_rows()
