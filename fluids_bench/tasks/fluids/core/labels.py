"""The supervisor's labels at every level and scale, on B worlds' rows: written once.

A label is what the supervisor does for an agent in the current (prepared) state, typed like an
action of the level the learner acts at, so that a learner can be trained on it:

* behaviour: the movement of the agent's entry lane of the route the supervisor drew for it
  (`Movements`), an integer;
* trajectory: the next `waypoints` points of its path, `waypoint_spacing` m apart, in its own
  frame (x forward, y left), flattened to `[x0, y0, x1, y1, ...]`;
* velocity: the supervisor's target speed (m/s);
* control: the supervisor's proposed controls as the control-level action in `[-1, 1]²`
  (`normalise`).

With `scale="normalized"` the trajectory and velocity labels are in the normalised action's
units (`actions.to_normalized`). A row is one agent of one world, as in `actions.act`:
`FluidsEnv` asks for its ego (B = 1, `label`), the PettingZoo env for one controlled car, the
vector env for the ego of every world whose supervisor just proposed (`label_rows`). The same
float operations in the same order on every row, so a label has the same bits in every face.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fluids_bench.tasks.fluids.core.actions import Movements, OneWorld, to_normalized
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING


def label_rows(
    level: str,
    scale: str,
    rows: tuple,
    worlds,
    plans,
    config,
    movements: Movements | None = None,
) -> np.ndarray:
    """The supervisor's label of each row's agent at `level` and `scale`.

    Args:
        level: the action level.
        scale: `"physical"` or `"normalized"` (the action scale).
        rows: the rows' `(world, agent)` index into (B, N, ...) arrays, each part selecting R
            rows (integer arrays, or an integer and an array); e.g. `(slice(0, 1), agent)`
            for one agent of one world.
        worlds: the worlds' rows (a `WorldBatch`, or `actions.OneWorld` of one world).
        plans: their supervisors' rows, read by name: `"behavior_routes"`, `"targets"` and
            `"proposed"` (a `SupervisorBatch`'s `plans`, or `actions.OneWorld` of one
            supervisor).
        config: the supervisors' configuration (`SupervisorConfig`: `waypoints`,
            `waypoint_spacing`).
        movements: the layout's `Movements` (built when not given).

    Returns:
        (R,) int64 at the behaviour level, else (R, k) float32 (k = 1 at the velocity level,
        2 at the control level, 2 · waypoints at the trajectory level).
    """
    world = worlds.worlds[0]
    if level == "behavior":  # the movement of the route drawn for the agent at spawn
        movements = Movements.of(world.layout) if movements is None else movements
        return movements.of_route[plans["behavior_routes"][rows]]
    if level == "control":
        return normalise(world.scene.car, plans["proposed"][rows])
    if level == "velocity":
        value = plans["targets"][rows][:, None]
    else:
        value = waypoints_ego_frame(worlds, rows, config)
    if scale == "normalized":
        value = to_normalized(level, world, value)
    return value.astype(np.float32)


def label(supervisor, world, level: str, agent: int = 0, scale: str = "physical"):
    """The supervisor's label for `agent` of `world` at `level` (B = 1: `label_rows` of one
    row), typed like an action of that level: an `int` at the behaviour level, else a float32
    array (with `scale="normalized"`, in the normalised action's units)."""
    rows = (_ONE, agent)
    out = label_rows(level, scale, rows, OneWorld(world), OneWorld(supervisor), supervisor.config)
    return int(out[0]) if level == "behavior" else out[0]


_ONE = slice(0, 1)  # the world of a B = 1 face


def normalise(car, controls: np.ndarray) -> np.ndarray:
    """Car controls (R, 2) `[ψ, F]` as control-level actions in `[-1, 1]`, float32 (R, 2):
    steering `ψ / max_steer`, force `F / max_force` (`F ≥ 0`) or `F / max_brake_force`,
    each clipped as Python's `min(max(v, -1), 1)` (NaN stays NaN). One compiled call."""
    return normalise_rows(controls, car.max_steer, car.max_force, car.max_brake_force)


@njit(cache=True, nogil=True)
def normalise_rows(controls, max_steer, max_force, max_brake_force):  # pragma: no cover
    """`normalise` of the rows `controls` (R, 2), with the car's limits."""
    out = np.empty(controls.shape, dtype=np.float32)
    for r in range(controls.shape[0]):
        steer = controls[r, 0] / max_steer
        force = controls[r, 1]
        force = force / (max_force if force >= 0 else max_brake_force)
        steer = -1.0 if -1.0 > steer else steer
        force = -1.0 if -1.0 > force else force
        out[r, 0] = 1.0 if 1.0 < steer else steer
        out[r, 1] = 1.0 if 1.0 < force else force
    return out


def waypoints_ego_frame(worlds, rows: tuple, config) -> np.ndarray:
    """The next `config.waypoints` points of each row's agent's path (R, 2 W),
    `config.waypoint_spacing` m apart, in its own frame: the nearest path samples
    (`World.path_points`), the same array operations on every row (numpy's cos and sin of a
    contiguous array)."""
    count = config.waypoints
    ahead = config.waypoint_spacing * np.arange(1, count + 1)
    s = np.minimum(worlds["s"][rows][:, None] + ahead, worlds["path_len"][rows][:, None])
    k = np.rint(s / PATH_SPACING).astype(np.int64)
    path = worlds["path_z"][rows]  # (R, P) complex: x + i y
    np.minimum(np.maximum(k, 0, out=k), path.shape[1] - 1, out=k)
    pts = path[np.arange(len(k))[:, None], k].view(np.float64).reshape(*k.shape, 2)
    own = worlds["state"][rows]
    x, y, th = own[:, 0:1], own[:, 1:2], np.ascontiguousarray(own[:, 2])
    dx, dy = pts[..., 0] - x, pts[..., 1] - y
    c, si = np.cos(th)[:, None], np.sin(th)[:, None]
    out = np.empty((len(own), count, 2))
    np.add(c * dx, si * dy, out=out[..., 0])
    np.add(-si * dx, c * dy, out=out[..., 1])
    return out.reshape(len(own), 2 * count)
