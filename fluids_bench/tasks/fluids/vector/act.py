"""The supervisor's labels at every level (behaviour, trajectory, velocity, control), for all
worlds of a batch at once.

`label_batch` is `FluidsEnv.supervisor_action` of the worlds whose supervisor just proposed,
read from the batch's rows. (What the agents do for the worlds' actions is
`fluids_bench.tasks.fluids.core.actions.act`, every face's.)
"""

from __future__ import annotations

import numpy as np

from fluids_bench.tasks.fluids.core import actions
from fluids_bench.tasks.fluids.core.actions import Movements
from fluids_bench.tasks.fluids.sim.batch import WorldBatch
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.supervisor.batch import SupervisorBatch


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
        movements = Movements.of(world.layout) if movements is None else movements
        labels[going] = movements.of_route[supervisors.plans["behavior_routes"][going, 0]]
        return
    if level in ("velocity", "trajectory"):
        value = (
            supervisors.plans["targets"][going, :1]
            if level == "velocity"
            else waypoints_ego_frame(worlds, going, first.supervisor.config)
        )
        if first.action_scale == "normalized":
            value = actions.to_normalized(level, world, value)
    else:  # DrivingSupervisor.normalise of the ego's proposed controls
        value = actions.normalise(world.scene.car, supervisors.proposed[going, 0])
    labels[going] = value
