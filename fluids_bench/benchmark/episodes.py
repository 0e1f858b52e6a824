"""One evaluation episode, and the resumable log of finished ones.

Every episode is a function of (policy, env id, env kwargs, seed) alone: the env is reset with
the seed, a policy that draws random numbers draws them from a generator of the same seed, so
the same episode gives the same row whatever process, worker count or order runs it. Rows are
appended to a JSON-lines file as they finish (one per episode, flushed): an interrupted
evaluation keeps them, and a rerun skips them.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from fluids_bench.algos.vector_rollout import (
    DEFAULT_BATCH,
    EpisodeEnd,
    has_vector_env,
    run_vector_episodes,
)
from fluids_bench.benchmark.policies import (
    PolicySource,
    actor_rng,
    batch_actor,
    batchable,
    build_actor,
)
from fluids_bench.core.jsonl import read_rows

SUCCESS_KEY = "is_success"
DRIVING_KEYS = ("driving_score", "route_completion", "infractions")  # FLUIDS-v4's info


@dataclass(frozen=True)
class EpisodeJob:
    """One episode to run: the policy's name (a key of the worker's sources) and where."""

    policy: str
    task: str
    set: str
    env_id: str
    env_kwargs_json: str  # sorted JSON of the env kwargs: part of the row's key
    seed: int

    def key(self) -> tuple[str, str, str, str, str, int]:
        return (self.policy, self.task, self.set, self.env_id, self.env_kwargs_json, self.seed)


def row_key(row: dict[str, Any]) -> tuple[str, str, str, str, str, int]:
    return (
        row["policy"], row["task"], row["set"], row["env_id"], row["env_kwargs"], int(row["seed"])
    )  # fmt: skip


def kwargs_json(kwargs: dict[str, Any]) -> str:
    return json.dumps(kwargs, sort_keys=True)


# per worker process: the policy sources (set by the pool's initializer), built actors and envs
_SOURCES: dict[tuple[str, str], PolicySource] = {}
_ACTORS: dict[tuple[str, str], Any] = {}
_ENVS: dict[tuple[str, str], gym.Env] = {}


def init_worker(sources: dict[tuple[str, str], PolicySource]) -> None:
    """Pool initializer: the policies this worker acts with, by (policy name, task name)."""
    import fluids_bench  # noqa: F401  (registers the ids in a fresh worker)

    _SOURCES.clear()
    _SOURCES.update(sources)
    _ACTORS.clear()


def _env(env_id: str, kwargs_text: str) -> gym.Env:
    key = (env_id, kwargs_text)
    if key not in _ENVS:
        _ENVS[key] = gym.make(env_id, **json.loads(kwargs_text))
    return _ENVS[key]


def _json_number(value: Any) -> Any:
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        return float(value)
    if isinstance(value, dict):
        return {str(k): _json_number(v) for k, v in value.items()}
    return value


def run_episode(job: EpisodeJob, task: Any = None) -> dict[str, Any]:
    """Run `job` to its end (termination or the id's time limit); its row."""
    env = _env(job.env_id, job.env_kwargs_json)
    actor = _actor(job, task)
    rng = actor_rng(job.seed)
    obs, info = env.reset(seed=job.seed)
    total, steps = 0.0, 0
    terminated = truncated = False
    while not (terminated or truncated):
        action = actor(obs, info, env, rng)
        obs, reward, terminated, truncated, info = env.step(action)
        total += float(reward)
        steps += 1
    return episode_row(job, total, steps, terminated, info)


def _actor(job: EpisodeJob, task: Any) -> Any:
    key = (job.policy, job.task)
    if key not in _ACTORS:
        _ACTORS[key] = build_actor(_SOURCES[key], task or job.task)
    return _ACTORS[key]


def episode_row(
    job: EpisodeJob, total: float, steps: int, terminated: bool, info: dict[str, Any]
) -> dict[str, Any]:
    """The log row of `job`'s episode: its return, length, end and last info's results."""
    row: dict[str, Any] = {
        "policy": job.policy,
        "task": job.task,
        "set": job.set,
        "env_id": job.env_id,
        "env_kwargs": job.env_kwargs_json,
        "seed": job.seed,
        "return": total,
        "length": steps,
        "terminated": bool(terminated),
        "success": bool(info[SUCCESS_KEY]) if SUCCESS_KEY in info else None,
    }
    for key in DRIVING_KEYS:
        if key in info:
            row[key] = _json_number(info[key])
    return row


def vector_group(job: EpisodeJob, task: Any = None) -> tuple[str, str, str, str] | None:
    """The jobs that may share one vector env as `job` (same policy, task, id and kwargs), or
    None when `job` runs alone: its id has no vector env, or its policy cannot act on a batch
    (an object with `act`, which may keep state from step to step)."""
    if not has_vector_env(job.env_id):
        return None
    if not batchable(_SOURCES[(job.policy, job.task)], _actor(job, task)):
        return None
    return (job.policy, job.task, job.env_id, job.env_kwargs_json)


def run_vector_jobs(
    jobs: list[EpisodeJob],
    task: Any,
    on_row: Callable[[dict[str, Any]], None],
    batch: int = DEFAULT_BATCH,
) -> None:
    """Run `jobs` (one `vector_group`) on their id's vector env, `batch` worlds at a time;
    each row, equal to `run_episode`'s, goes to `on_row` as its episode ends."""
    first = jobs[0]
    act = batch_actor(_SOURCES[(first.policy, first.task)], _actor(first, task))

    def end(episode: EpisodeEnd) -> None:
        job = jobs[episode.index]
        on_row(episode_row(job, episode.total_return, episode.length, episode.terminated,
                           episode.info))  # fmt: skip

    run_vector_episodes(
        first.env_id, json.loads(first.env_kwargs_json), [j.seed for j in jobs], act, actor_rng,
        end, batch=batch,
    )  # fmt: skip


def run_vector_chunk(jobs: list[EpisodeJob], task: Any, batch: int) -> list[dict[str, Any]]:
    """`run_vector_jobs` in a worker process: the rows, in the order the episodes ended."""
    rows: list[dict[str, Any]] = []
    run_vector_jobs(jobs, task, rows.append, batch)
    return rows


class EpisodeLog:
    """The append-only JSON-lines file of one policy's finished episodes."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = os.fspath(path)
        self.rows: dict[tuple[str, str, str, str, str, int], dict[str, Any]] = {}
        for row in read_rows(self.path):
            try:
                self.rows[row_key(row)] = row
            except (KeyError, TypeError, ValueError):
                continue  # a row of another layout: that episode is run again

    def done(self, job: EpisodeJob) -> bool:
        return job.key() in self.rows

    def get(self, job: EpisodeJob) -> dict[str, Any]:
        return self.rows[job.key()]

    def append(self, row: dict[str, Any]) -> None:
        os.makedirs(os.path.dirname(self.path) or ".", exist_ok=True)
        with open(self.path, "a+b") as f:  # end a torn last line first: the next row stays whole
            if f.tell() > 0:
                f.seek(-1, os.SEEK_END)
                if f.read(1) != b"\n":
                    f.write(b"\n")
        with open(self.path, "a", encoding="utf-8") as f:
            f.write(json.dumps(row, sort_keys=True) + "\n")
            f.flush()
            os.fsync(f.fileno())
        self.rows[row_key(row)] = row
