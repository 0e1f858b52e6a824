"""Actions and labels at every level (behaviour, trajectory, velocity, control), for all worlds
of a batch at once.

`FluidsEnv._act` world by world clips the ego's action, puts it in place of the supervisor's
at its level, and advances the PID loops' memory for the controls it returns.
`act_batch` does the same with array operations over the stepping worlds, operation for
operation the scalar env's (the clip as Python's `min(max(v, lo), hi)`, signed zeros
included), so each world's controls and memory are bit for bit what its own `_act` gives; at
the behaviour level a movement that changes the ego's route is taken world by world (a rare
event: the supervisor plans again). `label_batch` is `FluidsEnv.supervisor_action` of
the worlds whose supervisor just proposed, read from the batch's rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fluids_bench.tasks.fluids import levels
from fluids_bench.tasks.fluids.core import rules
from fluids_bench.tasks.fluids.sim.batch import WorldBatch
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.supervisor.batch import (
    PID_MEMORY,
    SupervisorBatch,
)


@dataclass(frozen=True)
class Movements:
    """A layout's movements as tables: the route of each movement of each entry lane (E, M;
    -1 past a lane's count), each lane's count (E,), and each car route's movement (R; -1 for
    walks), as `choose_movement` and
    `movement_of` read them."""

    routes: np.ndarray
    counts: np.ndarray
    of_route: np.ndarray

    @classmethod
    def of(cls, world) -> Movements:
        layout = world.layout
        lanes = [layout.routes_from_entry(e) for e in range(len(layout.entry_lanes))]
        routes = np.full((len(lanes), max(len(r) for r in lanes)), -1, dtype=np.int64)
        of_route = np.full(len(layout.routes.entry), -1, dtype=np.int64)
        for e, lane in enumerate(lanes):
            routes[e, : len(lane)] = lane
            of_route[lane] = np.arange(len(lane))
        return cls(routes, np.array([len(r) for r in lanes], dtype=np.int64), of_route)


def clip(values: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """`min(max(v, lo), hi)` elementwise, as Python's (which keeps `v` on ties)."""
    values = np.where(low > values, low, values)
    return np.where(high < values, high, values)


def act_batch(
    envs: list,
    actions: np.ndarray,
    stepping: np.ndarray,
    bounds: tuple[np.ndarray, np.ndarray] | None,
    worlds: WorldBatch,
    supervisors: SupervisorBatch,
    scratch: dict,
) -> None:
    """Write every stepping world's controls into `worlds.controls` and advance its PID
    memory, as `FluidsEnv._act` of its clipped action would, at any action level;
    `bounds`: the action space's low and high (flat, float64; None at the behaviour level);
    `scratch`: what this function keeps between calls."""
    first = envs[0]
    level, world = first.action_level, first.world
    if level == "behavior":
        if "movements" not in scratch:
            scratch["movements"] = Movements.of(world)
        movements = scratch["movements"]
        _choose_movements(envs, actions, stepping, worlds, movements)
        # the supervisor's proposal, made after any change of route
        worlds.controls[stepping] = supervisors.proposed[stepping]
        supervisors.commit_proposals(stepping)
        return
    values = clip(actions.reshape(len(envs), -1).astype(np.float64), *bounds)
    if first.action_scale == "normalized":
        values = levels.to_physical(level, world, values)
    # the ego's action counts while it drives ("all" mode: after arriving it is ignored)
    chosen = stepping & worlds["active"][:, 0]
    proposal = stepping & ~chosen if level in ("velocity", "trajectory") else stepping
    controls = worlds.controls
    controls[proposal] = supervisors.proposed[proposal]
    supervisors.commit_proposals(proposal)
    if level == "control":  # DrivingSupervisor.denormalise of the ego's row
        car = world.scene.car
        force = values[:, 1] * np.where(values[:, 1] >= 0, car.max_force, car.max_brake_force)
        ego = np.column_stack([values[:, 0] * car.max_steer, force])
        controls[chosen, 0] = ego[chosen]
        return
    memory = scratch.setdefault("memory", np.empty_like(supervisors.next_memory))
    if level == "trajectory":  # the ego steers to its waypoints, every agent to its target
        waypoints = values.reshape(len(envs), -1, 2)
        supervisors.follow_waypoints(chosen, worlds, waypoints, controls, memory)
    else:  # velocity: the PID toward the supervisor's targets with the ego's replaced
        targets = scratch.setdefault("targets", np.empty_like(supervisors.plans["targets"]))
        np.copyto(targets, supervisors.plans["targets"])
        targets[:, 0] = values[:, 0]
        supervisors.follow(chosen, worlds, targets, controls, memory)
    for k, name in enumerate(PID_MEMORY):  # PIDController.commit of that PID's memory
        supervisors.memory[name][chosen] = memory[chosen, k]


def _choose_movements(envs, actions, stepping, worlds: WorldBatch, movements: Movements) -> None:
    """`choose_movement` of each stepping world's ego (while it drives) for its behaviour
    action: the route of that movement of its entry lane, taken where it differs from the
    current one and the ego has not reached the junction nor left its route's path; where it
    is taken, world by world (a rare event), the ego follows it, the supervisor plans and
    proposes again and the env's route length is updated, as `FluidsEnv._act`."""
    route, s, offset = worlds["route"][:, 0], worlds["s"][:, 0], worlds["offset"][:, 0]
    w = worlds.worlds[0]
    routes = w.layout.routes
    lane = routes.entry[route]
    count = movements.counts[lane]
    new = movements.routes[lane, actions.astype(np.int64) % count]
    front = w.length[0] / 2
    change = (
        stepping
        & worlds["active"][:, 0]
        & (new != route)
        & ~(s + offset + front >= routes.enter_s[route])
        & (offset == 0)
    )
    for i in change.nonzero()[0].tolist():
        env = envs[i]
        env.world.follow_route(0, int(new[i]))
        env.supervisor.prepare(env.world)
        env._route_length = float(rules.route_length(env.world.path_len[0], env._last_s))


def waypoints_ego_frame(worlds: WorldBatch, mask: np.ndarray, config) -> np.ndarray:
    """`trajectory.waypoints_ego_frame` of the ego of each world where `mask` (M, 2 W):
    the next `config.waypoints` points of its path, `config.waypoint_spacing` m apart, in
    its own frame, the same array operations on every row (numpy's cos and sin of a contiguous
    array, as of the scalar)."""
    count = config.waypoints
    s = worlds["s"][mask, 0][:, None] + config.waypoint_spacing * np.arange(1, count + 1)
    s = np.minimum(s, worlds["path_len"][mask, 0][:, None])
    # World.path_points: the nearest path sample
    k = np.rint(s / PATH_SPACING).astype(np.int64)
    path = worlds["path_z"][mask, 0]
    np.minimum(np.maximum(k, 0, out=k), path.shape[1] - 1, out=k)
    pts = np.take_along_axis(path, k, axis=1).view(np.float64).reshape(*k.shape, 2)
    ego = worlds["state"][mask, 0]
    x, y, th = ego[:, 0:1], ego[:, 1:2], np.ascontiguousarray(ego[:, 2])
    dx, dy = pts[..., 0] - x, pts[..., 1] - y
    c, si = np.cos(th)[:, None], np.sin(th)[:, None]
    return np.stack([c * dx + si * dy, -si * dx + c * dy], axis=-1).reshape(len(ego), -1)


def label_batch(
    envs: list,
    going: np.ndarray,
    worlds: WorldBatch,
    supervisors: SupervisorBatch,
    labels: np.ndarray,
    movements: Movements | None = None,
) -> None:
    """Write into `labels` ((B,) int64 at the behaviour level, else (B, 1) or (B, 2)
    float32) the label of every world where `going` (its supervisor proposed in this step,
    from the batch's rows), as `levels.label` gives it; the other rows are left alone.
    `movements`: the layout's (`Movements`; built when not given)."""
    first = envs[0]
    level, world = first.action_level, first.world
    if level == "behavior":  # movement_of the route drawn for the ego at spawn
        movements = Movements.of(world) if movements is None else movements
        labels[going] = movements.of_route[supervisors.plans["behavior_routes"][going, 0]]
        return
    if level in ("velocity", "trajectory"):
        value = (
            supervisors.plans["targets"][going, :1]
            if level == "velocity"
            else waypoints_ego_frame(worlds, going, first.supervisor.config)
        )
        if first.action_scale == "normalized":
            value = levels.to_normalized(level, world, value)
    else:  # DrivingSupervisor.normalise of the ego's proposed controls
        car = world.scene.car
        steer, force = supervisors.proposed[going, 0, 0], supervisors.proposed[going, 0, 1]
        force = force / np.where(force >= 0, car.max_force, car.max_brake_force)
        value = clip(np.column_stack([steer / car.max_steer, force]), -1.0, 1.0)
    labels[going] = value
