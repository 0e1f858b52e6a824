"""Acting at a level of FLUIDS' supervisor hierarchy, for any set of controlled cars.

Shared by the single-agent env (the ego) and the multi-agent env (every controlled car): the
action space of each level, validation of an action, the supervisor's label as an action, and
the controls of every agent once the controlled cars' actions replace the supervisor's at their
level (the supervisor fills the levels below).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces

from fluids_bench.core.actions import check_box_action, check_discrete_action
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.behavior import choose_movement, movement_count
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor

ACTION_SCALES = ("physical", "normalized")
WAYPOINT_BOUND = 50.0  # m: trajectory-level waypoints lie in ±this in the car's frame


def action_space(level: str, world: World, waypoints: int, scale: str = "physical") -> spaces.Space:
    """The action space of `level`. `scale="normalized"`: every Box level is `[-1, 1]`
    (see `to_physical` for the map to physical units)."""
    if level == "behavior":
        return spaces.Discrete(movement_count(world))
    normalized = scale == "normalized"
    if level == "trajectory":
        bound = 1.0 if normalized else WAYPOINT_BOUND
        return spaces.Box(-bound, bound, (2 * waypoints,), np.float32)
    if level == "velocity":
        if normalized:
            return spaces.Box(-1.0, 1.0, (1,), np.float32)
        return spaces.Box(0.0, world.scene.car.max_speed, (1,), np.float32)
    return spaces.Box(-1.0, 1.0, (2,), np.float32)


def to_physical(level: str, world: World, action: np.ndarray) -> np.ndarray:
    """A normalised Box action (in `[-1, 1]`) in the level's physical units: velocity
    `(a + 1) / 2 · v_max` m/s, trajectory `a · 50` m; control is normalised already."""
    if level == "velocity":
        return (action + 1.0) * (0.5 * world.scene.car.max_speed)
    if level == "trajectory":
        return action * WAYPOINT_BOUND
    return action


def to_normalized(level: str, world: World, value: np.ndarray) -> np.ndarray:
    """The inverse of `to_physical`, clipped to `[-1, 1]`: the label in action units."""
    if level == "velocity":
        value = value * (2.0 / world.scene.car.max_speed) - 1.0
    elif level == "trajectory":
        value = value / WAYPOINT_BOUND
    # np.clip's bits (NaN stays NaN) at a third of its cost on a few numbers
    return np.minimum(np.maximum(value, -1.0), 1.0)


def validate(
    level: str,
    space: spaces.Space,
    action: Any,
    where: str,
    world: World | None = None,
    scale: str = "physical",
):
    """`action` as the env uses it; ValueError naming the level, what is wrong and what is
    allowed (the suite's shared check, `fluids_bench.core.actions.check_action`). Box
    actions must be real numbers of exactly the space's shape (strings, bools and complex
    numbers are refused, never coerced; `(1, n)` is not `(n,)`); out of bounds they are
    clipped; NaN and infinities are refused. `scale="normalized"`: the clipped action is
    returned in physical units (`to_physical`; needs `world`)."""
    if level == "behavior":
        return check_discrete_action(where, space, action, "behavior action")
    values = check_box_action(where, space, action, f"{level} action").tolist()
    bounds = space.low.reshape(-1).tolist(), space.high.reshape(-1).tolist()
    return clip(level, values, bounds, world, scale)


def clip(level: str, values: list[float], bounds: tuple[list, list], world=None, scale="physical"):
    """A checked Box action (its values as a flat list of floats) clipped to `bounds` (the
    space's low and high as flat lists), as `validate` returns it."""
    low, high = bounds
    out = np.array([min(max(v, lo), hi) for v, lo, hi in zip(values, low, high, strict=True)])
    return to_physical(level, world, out) if scale == "normalized" else out


def label(
    supervisor: DrivingSupervisor, world: World, level: str, agent: int, scale: str = "physical"
):
    """The supervisor's label for `agent` at `level`, typed like an action of that level
    (with `scale="normalized"`, in the normalised action's units)."""
    value = supervisor.label(world, level, agent)
    if level == "behavior":
        return int(value)
    if scale == "normalized" and level in ("velocity", "trajectory"):
        value = to_normalized(level, world, np.atleast_1d(np.asarray(value, dtype=np.float64)))
        return value.astype(np.float32)
    if level == "velocity":
        return np.array([value], dtype=np.float32)
    return np.asarray(value, dtype=np.float32)


def waypoints_aim(
    world: World, supervisor: DrivingSupervisor, agent: int, waypoints: np.ndarray
) -> np.ndarray:
    """The world-frame point car `agent` steers to for trajectory-level `waypoints` (its
    frame, flattened): the first one at least the PID look-ahead away, else the last."""
    pts = waypoints.reshape(-1, 2)
    pid = supervisor.config.pid
    ahead = max(pid.lookahead_min, pid.lookahead_time * world.state[agent, 3])
    far = np.flatnonzero(np.hypot(*pts.T) >= ahead)
    px, py = pts[far[0] if len(far) else -1]
    x, y, th, _ = world.state[agent]
    return np.array(
        [x + math.cos(th) * px - math.sin(th) * py, y + math.sin(th) * px + math.cos(th) * py]
    )


def controls(
    level: str, world: World, supervisor: DrivingSupervisor, chosen: dict[int, Any]
) -> tuple[np.ndarray, tuple | None, list[int]]:
    """Every agent's controls with the `chosen` agents' (validated) actions at `level`, the
    PID memory to commit (None: the supervisor's own), and the agents whose route changed."""
    w, sup = world, supervisor
    if not chosen:
        return sup.proposed, None, []
    if level == "behavior":
        changed = [i for i, movement in chosen.items() if choose_movement(w, i, movement)]
        if changed:
            sup.prepare(w)
        return sup.proposed, None, changed
    if level == "velocity":
        targets = sup.targets.copy()
        for i, a in chosen.items():
            targets[i] = float(a[0])
        return (*sup.pid.controls(w, targets), [])
    if level == "trajectory":
        aim = sup.pid.lookahead_points(w)
        for i, a in chosen.items():
            aim[i] = waypoints_aim(w, sup, i, a)
        return (*sup.pid.controls(w, sup.targets, aim), [])
    out = sup.proposed.copy()
    for i, a in chosen.items():
        out[i] = sup.denormalise(w, a)
    return out, None, []
