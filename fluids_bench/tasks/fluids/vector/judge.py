"""Termination, rewards and `is_success` of every world of a batch, as arrays.

`judge_worlds` is `FluidsEnv._judge_recorded` and `report_worlds` the reward and
`is_success` of `FluidsEnv._report` for all stepping worlds at once, read from the batch's
rows with the same float operations in the same order (so each world's reward has the bits the
scalar env gives it). Each env's episode bookkeeping (`_last_s`, `_ended`,
`_route_length`: what its snapshots hold) is read and written in its rows of the vector
env's `_progress` and `_done` arrays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fluids_bench.tasks.fluids.scenario import (
    COLLISION_PENALTY,
    SUCCESS_BONUS,
    VIOLATION_PENALTY,
)
from fluids_bench.tasks.fluids.sim.batch import FaultBatch, Rows, WorldBatch


@dataclass
class Judged:
    """One step's verdict for every world (entries of worlds that did not step are unused)."""

    terminated: np.ndarray  # bool (B,)
    ego_hit: np.ndarray  # bool (B,): the ego was in a new collision
    any_hit: np.ndarray  # bool (B,): the world had a new collision
    gained: np.ndarray  # (B,) metres of route the ego covered in the step
    broken: np.ndarray  # int (B,) rules the ego broke in the step


def judge_worlds(
    envs, stepping: np.ndarray, worlds: WorldBatch, episodes: Rows, events: list, broken
) -> Judged:
    """`FluidsEnv._judge_recorded` of the worlds where `stepping`, with `events` their
    new collisions and `broken` the rules their egos broke; `episodes`: the envs'
    `_progress` and `_done` rows."""
    env, rows = envs[0], worlds.rows
    any_hit, ego_hit = worlds.hit.copy(), np.zeros(len(envs), np.bool_)
    for i in any_hit.nonzero()[0].tolist():
        ego_hit[i] = any(e.a == 0 or e.b == 0 for e in events[i])
    reached = rows["reached"][:, 0]
    offset = rows["offset"][:, 0]
    # scenario.progress: past the path's end once arrived
    s_now = np.where(reached, rows["path_len"][:, 0] + offset, rows["s"][:, 0] + offset)
    last_s = episodes["_progress"][:, 0]
    gained = s_now - last_s
    if env.done_when == "ego":
        terminated = reached | ego_hit
    else:  # every car must arrive; any collision ends the episode
        terminated = rows["reached"][:, env.world.is_car].all(axis=1) | any_hit
    broken = np.asarray(broken, dtype=np.int64)
    if env.end_on_violation:  # is_success can no longer hold
        terminated |= broken > 0
    last_s[stepping] = s_now[stepping]
    episodes["_done"][stepping] = terminated[stepping]
    return Judged(terminated, ego_hit, any_hit, gained, broken)


def report_worlds(
    envs, judged: Judged, worlds: WorldBatch, faults: FaultBatch, episodes: Rows
) -> tuple[np.ndarray, np.ndarray]:
    """Each world's reward (B,) and `is_success` (B,; meaningful where it terminated), as
    `FluidsEnv._report` gives them (`step_reward`
    and `step_reward_v1`)."""
    env, rows = envs[0], worlds.rows
    if env.done_when == "ego":
        success = rows["reached"][:, 0] & ~rows["collided"][:, 0]
        failed_by = judged.ego_hit
    else:
        cars = env.world.is_car
        success = rows["reached"][:, cars].all(axis=1) & ~rows["collided"][:, cars].any(axis=1)
        failed_by = judged.any_hit
    if env.obey_lights:
        success &= ~faults["ran_red"][:, 0]
    if env.yield_to_pedestrians:
        success &= ~faults["failed_to_yield"][:, 0]
    route_length = episodes["_progress"][:, 1]
    if env.reward_version == 0:
        penalty = np.where(judged.ego_hit, COLLISION_PENALTY, 0.0)
        return judged.gained / route_length - penalty, success
    weight = env.failure_penalty
    penalty = np.where(failed_by, weight * COLLISION_PENALTY, 0.0)
    bonus = np.where(judged.terminated & success, SUCCESS_BONUS, 0.0)
    violations = weight * VIOLATION_PENALTY * judged.broken
    reward = judged.gained / route_length - penalty - violations + bonus
    return reward, success
