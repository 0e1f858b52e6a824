"""Evaluate one policy over every configuration of a `Grid`.

Configuration `i` runs `episodes` episodes of `FLUIDS-Sensitivity-v0` (velocity actions,
quasi-LIDAR observations, `done_when="all"`; `env_id="FLUIDS-Sensitivity-v1"` for the fair
benchmark's version: defensive background drivers, quasi-LIDAR v1, success also requires that
the ego obeys red lights) with the grid's keyword arguments, each through
`fluids_bench.algos.rollout.rollout` with the learner acting. Success is the source's:
every car reached its goal and nothing collided (`info["is_success"]`); a terminated episode
without success ended in a collision, a truncated one ran out of time.

Episode seeds come from `SeedSequence(seed, spawn_key=(i,))`: they depend on the sweep seed
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
from fluids_bench.core.parallel import run_tasks
from fluids_bench.sweep.grid import LEGACY_IDS, Grid, KwargGrid, env_kwargs
from fluids_bench.sweep.store import Layout, ResultStore

ENV_ID = "FLUIDS-Sensitivity-v0"  # the default (the source's setting)
ENV_IDS = LEGACY_IDS  # the ids of the source's six-parameter grid (Grid)
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
    """Everything configuration `index` depends on (what a worker receives)."""

    index: int
    configuration: dict[str, Any]
    env_id: str
    max_episode_steps: int | None
    seeds: tuple[int, ...]
    # a KwargGrid's configuration: the env kwargs (fixed ones included); None: the legacy grid
    kwargs: dict[str, Any] | None = None


def episode_seeds(seed: int, index: int, episodes: int) -> tuple[int, ...]:
    """The reset seeds of configuration `index`'s episodes."""
    state = np.random.SeedSequence(seed, spawn_key=(index,)).generate_state(episodes, np.uint32)
    return tuple(int(s) for s in state)


def evaluate_config(task: ConfigTask, policy: Any) -> dict[str, Any]:
    """Run one configuration's episodes; its result row. `cpu_seconds` (this process's CPU
    time for it) is reported but not stored: stored rows must reproduce exactly."""
    if task.kwargs is not None:
        return evaluate_kwarg_config(task, policy)
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


def evaluate_kwarg_config(task: ConfigTask, policy: Any) -> dict[str, Any]:
    """A KwargGrid configuration's row: successes (`info["is_success"]` at the end, where the
    env reports it), terminations, truncations and the episode returns."""
    cpu_start = time.process_time()
    assert task.kwargs is not None
    limit = {} if task.max_episode_steps is None else {"max_episode_steps": task.max_episode_steps}
    env = gym.make(task.env_id, **limit, **task.kwargs)
    actor: Actor = SUPERVISOR if policy is None else LearnerActor(policy)
    returns, successes, terminations, truncations, steps = [], 0, 0, 0, 0
    try:
        for seed in task.seeds:
            trajectory = rollout(env, actor, seed)
            successes += bool(trajectory.infos[-1].get("is_success", False))
            terminations += trajectory.terminated
            truncations += trajectory.truncated
            steps += len(trajectory)
            returns.append(float(trajectory.rewards.sum()))
    finally:
        env.close()
    episodes = len(task.seeds)
    values = np.asarray(returns, dtype=np.float64)
    return {
        "index": task.index,
        **task.configuration,
        "episodes": episodes,
        "successes": successes,
        "terminations": terminations,
        "truncations": truncations,
        "success_rate": successes / episodes,
        "mean_return": float(values.mean()),
        "std_return": float(values.std(ddof=1)) if episodes > 1 else 0.0,
        "mean_steps": steps / episodes,
        "cpu_seconds": time.process_time() - cpu_start,
    }


def check_env_id(env_id: str, grid: Grid | KwargGrid | None = None) -> str:
    """The source's six-parameter grid runs on the FLUIDS-Sensitivity ids only; a kwarg grid
    (and a policy trained for one) on any registered Gymnasium id."""
    if grid is not None and not grid.legacy:
        if not isinstance(env_id, str) or env_id not in gym.registry:
            raise ValueError(f"sweep: field 'env' is {env_id!r}; allowed: a registered id")
        return env_id
    if env_id not in ENV_IDS:
        raise ValueError(
            f"sweep: field 'env' is {env_id!r}; allowed: {list(ENV_IDS)} for the parameters "
            f"{list(Grid.default().names)}, or any registered id with --values NAME=V1,V2 over "
            "its keyword arguments"
        )
    return env_id


def configuration_kwargs(
    grid: Grid | KwargGrid, configuration: dict[str, Any], fixed: Mapping[str, Any] | None
) -> dict[str, Any]:
    """The env kwargs of one configuration: `fixed` ones, then the grid's."""
    return {**dict(fixed or {}), **grid.env_kwargs(configuration)}


def probe_env(
    grid: Grid | KwargGrid, env_id: str = ENV_ID, fixed: Mapping[str, Any] | None = None
) -> None:
    """Check every value of the grid with the env's own argument checks before any work: build
    the env (and reset it) at the grid's first and last configurations and, for a kwarg grid,
    at every single value of each parameter (the others at their first)."""
    check_env_id(env_id, grid)
    names = list(grid.values)
    picks = [{n: grid.values[n][0] for n in names}, {n: grid.values[n][-1] for n in names}]
    if not grid.legacy:
        for name in names:
            picks += [{**picks[0], name: value} for value in grid.values[name][1:-1]]
    for configuration in picks:
        try:
            env = gym.make(env_id, **configuration_kwargs(grid, configuration, fixed))
            env.reset(seed=0)
            env.close()
        except (ValueError, TypeError) as exc:
            hint = ""
            if not grid.legacy and set(names) & {"cars", "pedestrians"}:
                hint = (
                    f"; the source's six parameters {list(Grid.default().names)} belong to "
                    f"the 'env' ids {list(ENV_IDS)}"
                )
            raise ValueError(
                f"grid configuration {configuration} is not valid: {exc}{hint}"
            ) from exc


# -- the policy under evaluation ----------------------------------------------------------------


def policy_digest(policy_bytes: bytes | None) -> str:
    return SUPERVISOR_POLICY if policy_bytes is None else hashlib.sha256(policy_bytes).hexdigest()


def load_policy(path: str | Path) -> tuple[Any, bytes]:
    """A pickled policy (anything with `act(observation)`) and its bytes. Pickles run code:
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
    algo: str = "bc",
    iterations: int = 1,
) -> Path:
    """Behavior Cloning on `demos` supervisor demonstrations of `env_id` (its defaults: 4
    cars, 2 pedestrians, lights on, no sensor noise, 1500 kg), quasi-LIDAR to target velocity,
    every state–label pair kept. Cached in `folder/policy.pkl` with the training settings in
    `policy.json`; an existing cache made with the same settings is reused; one made with
    other settings is replaced only when `replace`. `before_training` is called only when
    training is needed, before it starts (a place to refuse early).

    `check_episodes`: also run the trained policy on that many seeded episodes of the
    training distribution itself (seeds `CHECK_SEED + i`, never trained on) and record its
    in-distribution success rate in `policy.json` (`in_distribution`). `train_kwargs`:
    env keyword arguments for the demonstrations (e.g. `{"lidar_noise": 1.0}`, an ablation:
    BC trained on what it will be tested on); the check then runs under them too."""
    from fluids_bench.algos.policies import PolicySpec
    from fluids_bench.algos.registry import get_algorithm

    path, info_path = folder / POLICY_FILE, folder / "policy.json"
    train_kwargs = dict(train_kwargs or {})
    if env_id not in gym.registry:
        raise ValueError(f"sweep: field 'env' is {env_id!r}; allowed: a registered id")
    algorithm = get_algorithm(algo)
    config = algorithm.config_class(
        **{
            **algorithm.presets,
            "env_id": env_id,
            "env_kwargs": train_kwargs,
            "policy": PolicySpec(learner),
            "iterations": iterations,
            "demos_per_iteration": demos,
            "samples_per_demo": None,
            "eval_episodes": 1,
            "seed": seed,
        }
    )
    run = algorithm.run
    settings = json.loads(json.dumps({"algo": algo, "config": config.to_dict()}))
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
    """Success of `policy` (None: the supervisor) on `episodes` seeded episodes of
    `env_id` with its registered defaults and `env_kwargs` (the distribution BC trains on)."""
    limit = {"max_episode_steps": MAX_EPISODE_STEPS} if env_id in ENV_IDS else {}
    env = gym.make(env_id, **limit, **dict(env_kwargs or {}))
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
    grid: Grid | KwargGrid,
    episodes: int,
    seed: int,
    max_episode_steps: int | None,
    policy_bytes: bytes | None,
    env_id: str = ENV_ID,
    fixed: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """What a sweep's rows depend on (the store refuses to resume under another manifest).
    Format 1: the FLUIDS-Sensitivity six-parameter grid; format 2: a kwarg grid (its value
    kinds, the fixed env kwargs; `max_episode_steps` None is the registered limit)."""
    if not grid.legacy:
        return {
            "format": 2,
            "env_id": env_id,
            "grid": grid.to_dict(),
            "kinds": grid.kinds,
            "env_kwargs": dict(fixed or {}),
            "episodes": episodes,
            "seed": seed,
            "max_episode_steps": max_episode_steps,
            "policy_sha256": policy_digest(policy_bytes),
        }
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
    grid: Grid | KwargGrid,
    episodes: int,
    seed: int,
    max_episode_steps: int | None,
    env_id: str = ENV_ID,
    fixed: Mapping[str, Any] | None = None,
) -> None:
    """Refuse, before a new policy is trained, a folder that already holds a sweep: its rows were
    made with another policy (a cached default policy would have been reused), and maybe with
    other settings too. `FileExistsError` names what differs."""
    existing = ResultStore(folder).read_manifest()
    if existing is None:
        return
    wanted = manifest(grid, episodes, seed, max_episode_steps, None, env_id, fixed)
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
    grid: Grid | KwargGrid,
    policy: Any,
    policy_bytes: bytes | None,
    *,
    episodes: int = 20,
    seed: int = 0,
    max_episode_steps: int | None = MAX_EPISODE_STEPS,
    backend: str = "process",
    workers: int = 1,
    address: str | None = None,
    overwrite: bool = False,
    on_start: Callable[[int, int], None] | None = None,
    on_row: Callable[[Mapping[str, Any]], None] | None = None,
    env_id: str = ENV_ID,
    fixed: Mapping[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """Evaluate `policy` (None: the supervisor) on every configuration of `env_id` not yet
    in `folder`.

    `on_start(done, total)` is called once the finished rows are known, `on_row(row)` after
    each new row is stored. Returns all rows, sorted by configuration index.
    """
    generic = not grid.legacy
    with ResultStore(folder, Layout.of(grid)) as store:
        done = store.open(
            manifest(
                grid,
                episodes,
                seed,
                max_episode_steps,
                policy_bytes,
                check_env_id(env_id, grid),
                fixed,
            ),
            overwrite,
        )
        if on_start is not None:
            on_start(len(done), len(grid))
        tasks = (
            ConfigTask(
                index,
                config,
                env_id,
                max_episode_steps,
                episode_seeds(seed, index, episodes),
                configuration_kwargs(grid, config, fixed) if generic else None,
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
