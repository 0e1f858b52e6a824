"""Actions at every level decoded into what the agents do, on B worlds' rows: written once.

A row is one acting agent of one world: a world's ego (`FluidsEnv` is B = 1, the vector env has
one row per world whose ego drives) or one controlled car of the multi-agent env (B = 1, one row
per agent that sent an action). `act` takes the rows' actions (checked, clipped by `clip` and in
physical units by `to_physical`), puts each in place of the supervisor's at its level, lets the
supervisor fill the levels below, writes every stepping world's controls and advances its PID
loops' memory for them:

* behaviour: a movement of the agent's entry lane (`Movements`), taken while it has not reached
  the junction nor left its route's path; where a route changes, the world's supervisor plans and
  proposes again; every agent then drives the supervisor's proposal;
* trajectory: the agent steers to the first of its waypoints (its own frame) at least its PID
  look-ahead away, else the last; every agent follows its PID toward the supervisor's targets;
* velocity: the agent's target speed replaces the supervisor's, then the PID as above;
* control: the agent's `[steer, force]` (`denormalise`), the others the supervisor's proposal.

Each level is one compiled call over the B worlds (`behavior_worlds`, `control_worlds`,
`velocity_worlds`, `trajectory_worlds`), so B = 1 pays no batch overhead. The same float
operations in the same order on every row, whichever face calls, so a world's step has the
same bits in the scalar, vector and multi-agent envs.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.supervisor.batch import PID_MEMORY
from fluids_bench.tasks.fluids.supervisor.kernels import (
    lookahead_points,
    pid_controls_into,
    pid_follow_into,
)

ACTION_SCALES = ("physical", "normalized")
WAYPOINT_BOUND = 50.0  # m: trajectory-level waypoints lie in ±this in the car's frame


def to_physical(level: str, world, action: np.ndarray) -> np.ndarray:
    """A normalised Box action (in `[-1, 1]`, any leading axes) in the level's physical units:
    velocity `(a + 1) / 2 · v_max` m/s, trajectory `a · 50` m; control is normalised already."""
    if level == "velocity":
        return (action + 1.0) * (0.5 * world.scene.car.max_speed)
    if level == "trajectory":
        return action * WAYPOINT_BOUND
    return action


def to_normalized(level: str, world, value: np.ndarray) -> np.ndarray:
    """The inverse of `to_physical`, clipped to `[-1, 1]`: a label in action units."""
    if level == "velocity":
        value = value * (2.0 / world.scene.car.max_speed) - 1.0
    elif level == "trajectory":
        value = value / WAYPOINT_BOUND
    # np.clip's bits (NaN stays NaN) at a third of its cost on a few numbers
    return np.minimum(np.maximum(value, -1.0), 1.0)


def clip(values: np.ndarray, low: Any, high: Any) -> np.ndarray:
    """`min(max(v, lo), hi)` elementwise, as Python's (which keeps `v` on ties: signed zeros
    stay). One action (1-D): with Python floats, which cost less than numpy calls on a few
    numbers (the bits are the same)."""
    if values.ndim == 1:
        bounds = zip(values.tolist(), np.ravel(low).tolist(), np.ravel(high).tolist(), strict=True)
        return np.array([min(max(v, lo), hi) for v, lo, hi in bounds])
    values = np.where(low > values, low, values)
    return np.where(high < values, high, values)


def denormalise(car, values: np.ndarray) -> np.ndarray:
    """Control-level actions (R, 2) in `[-1, 1]` as car controls (R, 2): `[ψ, F]`."""
    force = values[:, 1] * np.where(values[:, 1] >= 0, car.max_force, car.max_brake_force)
    return np.column_stack([values[:, 0] * car.max_steer, force])


@dataclass(frozen=True)
class Movements:
    """A layout's movements as tables: the route of each movement of each entry lane (E, M;
    -1 past a lane's count), each lane's count (E,), and each car route's movement (R; -1 for
    walks)."""

    routes: np.ndarray
    counts: np.ndarray
    of_route: np.ndarray

    @staticmethod
    @functools.lru_cache(maxsize=32)
    def of(layout) -> Movements:
        lanes = [layout.routes_from_entry(e) for e in range(len(layout.entry_lanes))]
        routes = np.full((len(lanes), max(len(r) for r in lanes)), -1, dtype=np.int64)
        of_route = np.full(len(layout.routes.entry), -1, dtype=np.int64)
        for e, lane in enumerate(lanes):
            routes[e, : len(lane)] = lane
            of_route[lane] = np.arange(len(lane))
        return Movements(routes, np.array([len(r) for r in lanes], dtype=np.int64), of_route)


@dataclass(slots=True)
class Pilots:
    """What `act` reads and writes of B worlds' supervisors: their rows (B, ...) of the velocity
    targets, the last proposal (controls (B, N, 2) and the PID memory after them (B, 3, N)),
    the PID loops' memory (B, N each, `PID_MEMORY`), and the supervisors themselves (all of one
    configuration: the first lends the PID's constants)."""

    targets: np.ndarray
    proposed: np.ndarray
    next_memory: np.ndarray
    memory: tuple[np.ndarray, np.ndarray, np.ndarray]
    supervisors: list

    @classmethod
    def of_batch(cls, batch) -> Pilots:
        """A `SupervisorBatch`'s rows."""
        memory = tuple(batch.memory[name] for name in PID_MEMORY)
        return cls(batch.plans["targets"], batch.proposed, batch.next_memory, memory,
                   batch.supervisors)  # fmt: skip

    @classmethod
    def of_one(cls, supervisor) -> Pilots:
        """One supervisor's arrays as B = 1 rows (views: written in place)."""
        pid = supervisor.pid
        memory = (pid.steer_prev[None], pid.steer_int[None], pid.speed_int[None])
        return cls(supervisor.targets[None], supervisor.proposed[None],
                   supervisor._memory[None], memory, [supervisor])  # fmt: skip


class OneWorld:
    """One world's arrays as B = 1 rows, read as a `WorldBatch`'s (`world["s"]`: (1, N)); or
    one supervisor's, read as a `SupervisorBatch`'s `plans` (`core.labels`)."""

    __slots__ = ("worlds",)

    def __init__(self, world) -> None:
        self.worlds = [world]

    def __getitem__(self, name: str) -> np.ndarray:
        return getattr(self.worlds[0], name)[None]


def act(
    level: str,
    world_of: np.ndarray,
    agent_of: np.ndarray,
    values: np.ndarray,
    going: np.ndarray,
    worlds,
    pilots: Pilots,
    out: np.ndarray,
) -> np.ndarray:
    """Write the controls (B, N, 2) of every world where `going` into `out` with each row's
    action in place of the supervisor's at `level`, and commit its PID memory for them (one
    compiled call at every level, whatever B).

    Args:
        level: the action level.
        world_of: each row's world (R,), ascending; only worlds where `going`.
        agent_of: each row's agent (R,).
        values: each row's action, checked, clipped and in physical units ((R, k) floats;
            (R,) or (R, 1) integers at the behaviour level).
        going: the worlds that step (B,) bool.
        worlds: the worlds' rows (a `WorldBatch`, or `OneWorld`).
        pilots: their supervisors' rows (`Pilots`).
        out: the controls (B, N, 2); the rows of the worlds not going are left alone.

    Returns:
        The rows whose route changed (indices into the rows; behaviour level only): each
        face updates its route length for them.
    """
    proposal = (pilots.proposed, pilots.next_memory, *pilots.memory, out)
    if not len(world_of):  # the supervisor's proposal everywhere
        propose_worlds(going, *proposal)
        return _NONE
    if level == "behavior":
        return choose_movements(world_of, agent_of, values, going, worlds, pilots, out)
    if level == "control":
        car = worlds.worlds[0].scene.car
        control_worlds(
            going, world_of, agent_of, values, car.max_steer, car.max_force,
            car.max_brake_force, *proposal,
        )  # fmt: skip
        return _NONE
    sup, w = pilots.supervisors[0], worlds.worlds[0]
    pid, cfg = sup.pid, sup.config.pid
    follow = (
        worlds["path_z"], worlds["s"], worlds["path_len"], pid.min_ahead, pid.ahead_time,
        PATH_SPACING, worlds["state"], pid.is_car, pilots.targets, w.dt, pid._gains,
        pid._limits, pid.gain, pid.low, pid.high,
    )  # fmt: skip
    if level == "velocity":
        velocity_worlds(going, world_of, agent_of, values, *follow, *proposal)
    else:  # trajectory: waypoints (R, W, 2)
        waypoints = values.reshape(len(values), -1, 2)
        trajectory_worlds(
            going, world_of, agent_of, waypoints, cfg.lookahead_min, cfg.lookahead_time,
            *follow, *proposal,
        )  # fmt: skip
    return _NONE


_NONE = np.zeros(0, dtype=np.int64)


def choose_movements(world_of, agent_of, movements, going, worlds, pilots: Pilots, out):
    """Each row's behaviour action: the route of that movement (modulo its lane's count) of
    the agent's entry lane, taken where it differs from the current one and the agent has not
    reached the junction nor left its route's path; every world where `going` drives its
    supervisor's proposal (`behavior_worlds`). Where a route changes (a rare event) the agent
    follows it and its world's supervisor plans and proposes again, which that world then
    drives. Returns the rows whose route changed."""
    first = worlds.worlds[0]
    routes, table = first.layout.routes, Movements.of(first.layout)
    new = np.empty(len(world_of), dtype=np.int64)
    proposal = (pilots.proposed, pilots.next_memory, *pilots.memory, out)
    rows = behavior_worlds(
        going, world_of, agent_of, np.asarray(movements, dtype=np.int64).reshape(-1),
        worlds["route"], worlds["s"], worlds["offset"], first.length, routes.entry,
        table.routes, table.counts, routes.enter_s, new, *proposal,
    ).nonzero()[0]  # fmt: skip
    if not len(rows):
        return rows
    for r in rows.tolist():
        worlds.worlds[world_of[r]].follow_route(int(agent_of[r]), int(new[r]))
    again = np.zeros(len(going), dtype=np.bool_)
    again[world_of[rows]] = True
    for b in again.nonzero()[0].tolist():
        pilots.supervisors[b].prepare(worlds.worlds[b])
    propose_worlds(again, *proposal)
    return rows


# ------------------------------------------------------------------ compiled, on B worlds' rows
@njit(cache=True, nogil=True)
def behavior_worlds(
    going, world_of, agent_of, movements, route, s, offset, length, entry, lane_routes, counts,
    enter_s, new, proposed, next_memory, steer_prev, steer_int, speed_int, out,
):  # fmt: skip  # pragma: no cover (compiled)
    """Where each row's movement changes its agent's route (to `new[r]`): it differs from
    the current one, the agent's front is short of the junction and it is on its route's
    path. Every world where `going` and no route changes drives its proposal (`_propose`;
    the others plan again first)."""
    change = np.zeros(len(world_of), dtype=np.bool_)
    again = np.zeros(len(going), dtype=np.bool_)
    for r in range(len(world_of)):
        b, i = world_of[r], agent_of[r]
        now = route[b, i]
        lane = entry[now]
        new[r] = lane_routes[lane, movements[r] % counts[lane]]
        front = length[i] / 2
        change[r] = (
            new[r] != now and not (s[b, i] + offset[b, i] + front >= enter_s[now])
        ) and offset[b, i] == 0
        if change[r]:
            again[b] = True
    for b in range(len(going)):
        if going[b] and not again[b]:
            _propose(b, proposed, next_memory, steer_prev, steer_int, speed_int, out)
    return change


@njit(cache=True, nogil=True)
def _propose(b, proposed, next_memory, steer_prev, steer_int, speed_int, out):  # pragma: no cover
    """World `b` drives its supervisor's proposal; its PID memory is the proposal's."""
    out[b] = proposed[b]
    steer_prev[b], steer_int[b], speed_int[b] = (
        next_memory[b, 0],
        next_memory[b, 1],
        next_memory[b, 2],
    )


@njit(cache=True, nogil=True)
def propose_worlds(
    going, proposed, next_memory, steer_prev, steer_int, speed_int, out
):  # pragma: no cover (compiled)
    """`_propose` for every world where `going`."""
    for b in range(len(going)):
        if going[b]:
            _propose(b, proposed, next_memory, steer_prev, steer_int, speed_int, out)


@njit(cache=True, nogil=True)
def control_worlds(
    going, world_of, agent_of, values, max_steer, max_force, max_brake_force, proposed,
    next_memory, steer_prev, steer_int, speed_int, out,
):  # fmt: skip  # pragma: no cover (compiled)
    """Every world where `going` drives its proposal, each row's agent its control-level
    action `[a, b]` in `[-1, 1]`: steering `a · max_steer`, force `b · max_force` (`b ≥ 0`)
    or `b · max_brake_force`."""
    propose_worlds(going, proposed, next_memory, steer_prev, steer_int, speed_int, out)
    for r in range(len(world_of)):
        b, i = world_of[r], agent_of[r]
        steer, force = values[r, 0], values[r, 1]
        out[b, i, 0] = steer * max_steer
        out[b, i, 1] = force * (max_force if force >= 0 else max_brake_force)


@njit(cache=True, nogil=True)
def velocity_worlds(
    going, world_of, agent_of, values, path_z, s, path_len, min_ahead, ahead_time, spacing,
    state, is_car, targets, dt, gains, limits, gain, low, high, proposed, next_memory,
    steer_prev, steer_int, speed_int, out,
):  # fmt: skip  # pragma: no cover (compiled)
    """Every world where `going`: with rows (sorted by world), its PID toward the
    supervisor's `targets` with each row's agent's target speed its action `values[r, 0]`
    (m/s), and that PID's memory committed; without, its proposal."""
    memory = np.empty((3, targets.shape[1]))
    r = 0
    for b in range(len(going)):
        if not going[b]:
            continue
        while r < len(world_of) and world_of[r] < b:
            r += 1
        if r == len(world_of) or world_of[r] != b:
            _propose(b, proposed, next_memory, steer_prev, steer_int, speed_int, out)
            continue
        speeds = targets[b].copy()
        while r < len(world_of) and world_of[r] == b:
            speeds[agent_of[r]] = values[r, 0]
            r += 1
        pid_follow_into(
            path_z[b], s[b], path_len[b], min_ahead, ahead_time, spacing, state[b], is_car,
            speeds, steer_prev[b], steer_int[b], speed_int[b], dt, gains, limits, gain, low,
            high, out[b], memory,
        )  # fmt: skip
        steer_prev[b], steer_int[b], speed_int[b] = memory[0], memory[1], memory[2]


@njit(cache=True, nogil=True)
def trajectory_worlds(
    going, world_of, agent_of, waypoints, lookahead_min, lookahead_time, path_z, s, path_len,
    min_ahead, ahead_time, spacing, state, is_car, targets, dt, gains, limits, gain, low, high,
    proposed, next_memory, steer_prev, steer_int, speed_int, out,
):  # fmt: skip  # pragma: no cover (compiled)
    """Every world where `going`: with rows (sorted by world), its PID toward the
    supervisor's `targets`, each row's agent steering to the first of its trajectory-level
    `waypoints[r]` (W, 2; m, its own frame) at least its look-ahead away (else the last),
    every other agent to its look-ahead point, and that PID's memory committed (the C
    library's hypot, cos and sin, as `math`'s); without rows, its proposal."""
    memory = np.empty((3, targets.shape[1]))
    r = 0
    for b in range(len(going)):
        if not going[b]:
            continue
        while r < len(world_of) and world_of[r] < b:
            r += 1
        if r == len(world_of) or world_of[r] != b:
            _propose(b, proposed, next_memory, steer_prev, steer_int, speed_int, out)
            continue
        aim = lookahead_points(
            path_z[b], s[b], state[b], path_len[b], min_ahead, ahead_time, spacing
        )
        while r < len(world_of) and world_of[r] == b:
            i = agent_of[r]
            ahead = max(lookahead_min, lookahead_time * state[b, i, 3])
            k = waypoints.shape[1] - 1
            for j in range(waypoints.shape[1]):
                if math.hypot(waypoints[r, j, 0], waypoints[r, j, 1]) >= ahead:
                    k = j
                    break
            px, py = waypoints[r, k, 0], waypoints[r, k, 1]
            x, y, th = state[b, i, 0], state[b, i, 1], state[b, i, 2]
            aim[i, 0] = x + math.cos(th) * px - math.sin(th) * py
            aim[i, 1] = y + math.sin(th) * px + math.cos(th) * py
            r += 1
        pid_controls_into(
            state[b], aim, is_car, targets[b], steer_prev[b], steer_int[b], speed_int[b], dt,
            gains, limits, gain, low, high, out[b], memory[0], memory[1], memory[2],
        )  # fmt: skip
        steer_prev[b], steer_int[b], speed_int[b] = memory[0], memory[1], memory[2]
