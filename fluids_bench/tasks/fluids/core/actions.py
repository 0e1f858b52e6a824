"""What the agents do for actions at every level, decoded on B worlds' rows: the one place this lives.

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

The same float operations in the same order on every row, whichever face calls, so a world's
step has the same bits in the scalar, vector and multi-agent envs.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.supervisor.batch import PID_MEMORY, pid_follow_worlds
from fluids_bench.tasks.fluids.supervisor.kernels import lookahead_points, pid_controls_into

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
    stay)."""
    values = np.where(low > values, low, values)
    return np.where(high < values, high, values)


def denormalise(car, values: np.ndarray) -> np.ndarray:
    """Control-level actions (R, 2) in `[-1, 1]` as car controls (R, 2): `[ψ, F]`."""
    force = values[:, 1] * np.where(values[:, 1] >= 0, car.max_force, car.max_brake_force)
    return np.column_stack([values[:, 0] * car.max_steer, force])


def normalise(car, controls: np.ndarray) -> np.ndarray:
    """Car controls (R, 2) `[ψ, F]` as control-level actions in `[-1, 1]` (a label)."""
    steer, force = controls[:, 0], controls[:, 1]
    force = force / np.where(force >= 0, car.max_force, car.max_brake_force)
    return clip(np.column_stack([steer / car.max_steer, force]), -1.0, 1.0)


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

    def commit(self, mask: np.ndarray, memory: np.ndarray) -> None:
        """`PIDController.commit` of `memory` (B, 3, N) for each world where `mask`."""
        for k, rows in enumerate(self.memory):
            rows[mask] = memory[mask, k]


class OneWorld:
    """One world's arrays as B = 1 rows, read as a `WorldBatch`'s (`world["s"]`: (1, N))."""

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
    action in place of the supervisor's at `level`, and commit its PID memory for them.

    Args:
        level: the action level.
        world_of: each row's world (R,), ascending; only worlds where `going`.
        agent_of: each row's agent (R,).
        values: each row's action, checked, clipped and in physical units ((R, k) floats;
            (R,) integers at the behaviour level).
        going: the worlds that step (B,) bool.
        worlds: the worlds' rows (a `WorldBatch`, or `OneWorld`).
        pilots: their supervisors' rows (`Pilots`).
        out: the controls (B, N, 2); the rows of the worlds not going are left alone.

    Returns:
        The rows whose route changed (indices into the rows; behaviour level only): each
        face updates its route length for them.
    """
    if level == "behavior":
        changed = choose_movements(world_of, agent_of, values, worlds, pilots)
        out[going] = pilots.proposed[going]  # the proposal, made after any change of route
        pilots.commit(going, pilots.next_memory)
        return changed
    acting = np.zeros(len(going), dtype=np.bool_)
    acting[world_of] = True
    # at the control level every world's PID memory is that of its proposal
    proposal = going & ~acting if level in ("velocity", "trajectory") else going
    out[proposal] = pilots.proposed[proposal]
    pilots.commit(proposal, pilots.next_memory)
    if not len(world_of):
        return _NONE
    if level == "control":
        out[world_of, agent_of] = denormalise(worlds.worlds[0].scene.car, values)
        return _NONE
    memory = np.empty_like(pilots.next_memory)
    sup, w = pilots.supervisors[0], worlds.worlds[0]
    pid = sup.pid
    targets = pilots.targets
    if level == "velocity":
        targets = targets.copy()
        targets[world_of, agent_of] = values[:, 0]
        pid_follow_worlds(
            acting, worlds["path_z"], worlds["s"], worlds["path_len"], pid.min_ahead,
            pid.ahead_time, PATH_SPACING, worlds["state"], pid.is_car, targets, *pilots.memory,
            w.dt, pid._gains, pid._limits, pid.gain, pid.low, pid.high, out, memory,
        )  # fmt: skip
    else:  # trajectory
        cfg = sup.config.pid
        waypoints = np.ascontiguousarray(values).reshape(len(values), -1, 2)
        follow_waypoints(
            acting, world_of, agent_of, waypoints, cfg.lookahead_min, cfg.lookahead_time,
            worlds["path_z"], worlds["s"], worlds["path_len"], pid.min_ahead, pid.ahead_time,
            PATH_SPACING, worlds["state"], pid.is_car, targets, *pilots.memory, w.dt,
            pid._gains, pid._limits, pid.gain, pid.low, pid.high, out, memory,
        )  # fmt: skip
    pilots.commit(acting, memory)
    return _NONE


_NONE = np.zeros(0, dtype=np.int64)


def choose_movements(world_of, agent_of, movements, worlds, pilots: Pilots) -> np.ndarray:
    """Each row's behaviour action: the route of that movement (modulo its lane's count) of
    the agent's entry lane, taken where it differs from the current one and the agent has not
    reached the junction nor left its route's path. Where one is taken (a rare event) the
    agent follows it and its world's supervisor plans and proposes again. Returns the rows
    whose route changed."""
    if not len(world_of):
        return _NONE
    movements = np.asarray(movements).reshape(len(world_of)).astype(np.int64)
    first = worlds.worlds[0]
    routes, table = first.layout.routes, Movements.of(first.layout)
    route = worlds["route"][world_of, agent_of]
    s, offset = worlds["s"][world_of, agent_of], worlds["offset"][world_of, agent_of]
    lane = routes.entry[route]
    new = table.routes[lane, movements % table.counts[lane]]
    front = first.length[agent_of] / 2
    change = (new != route) & ~(s + offset + front >= routes.enter_s[route]) & (offset == 0)
    rows = change.nonzero()[0]
    for r in rows.tolist():
        worlds.worlds[world_of[r]].follow_route(int(agent_of[r]), int(new[r]))
    for b in np.unique(world_of[rows]).tolist():
        pilots.supervisors[b].prepare(worlds.worlds[b])
    return rows


@njit(cache=True, nogil=True)
def follow_waypoints(
    acting, world_of, agent_of, waypoints, lookahead_min, lookahead_time, path_z, s, path_len,
    min_ahead, ahead_time, spacing, state, is_car, targets, steer_prev, steer_int, speed_int, dt,
    gains, limits, gain, low, high, out, memory,
):  # fmt: skip  # pragma: no cover (compiled)
    """Where `acting[b]`: the controls (into `out[b]`) and next PID memory (`memory[b]`)
    of world `b` with each of its rows' agent steering to the first of its trajectory-level
    `waypoints[r]` (W, 2; its own frame) at least its look-ahead away (else the last) and
    every other agent to its look-ahead point, all toward `targets[b]` (the C library's
    hypot, cos and sin, as `math`'s). Rows are sorted by world."""
    r = 0
    for b in range(len(acting)):
        if not acting[b]:
            continue
        aim = lookahead_points(
            path_z[b], s[b], state[b], path_len[b], min_ahead, ahead_time, spacing
        )
        while r < len(world_of) and world_of[r] < b:
            r += 1
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
            gains, limits, gain, low, high, out[b], memory[b, 0], memory[b, 1], memory[b, 2],
        )  # fmt: skip
