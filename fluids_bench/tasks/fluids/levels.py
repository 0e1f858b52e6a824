"""Acting at a level of FLUIDS' supervisor hierarchy, for any set of controlled cars: the
action space of each level and validation of one action.

Shared by the single-agent env (the ego) and the multi-agent env (every controlled car). What
the agents then do for the actions (every face's decoding) is
`fluids_bench.tasks.fluids.core.actions`; the supervisor's label as an action is
`fluids_bench.tasks.fluids.core.labels`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from fluids_bench.core.actions import check_box_action, check_discrete_action
from fluids_bench.tasks.fluids.core import actions
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.behavior import movement_count


def action_space(level: str, world: World, waypoints: int, scale: str = "physical") -> spaces.Space:
    """The action space of `level`. `scale="normalized"`: every Box level is `[-1, 1]`
    (see `actions.to_physical` for the map to physical units)."""
    if level == "behavior":
        return spaces.Discrete(movement_count(world))
    normalized = scale == "normalized"
    if level == "trajectory":
        bound = 1.0 if normalized else actions.WAYPOINT_BOUND
        return spaces.Box(-bound, bound, (2 * waypoints,), np.float32)
    if level == "velocity":
        if normalized:
            return spaces.Box(-1.0, 1.0, (1,), np.float32)
        return spaces.Box(0.0, world.scene.car.max_speed, (1,), np.float32)
    return spaces.Box(-1.0, 1.0, (2,), np.float32)


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
    returned in physical units (`actions.to_physical`; needs `world`)."""
    if level == "behavior":
        return check_discrete_action(where, space, action, "behavior action")
    values = check_box_action(where, space, action, f"{level} action")
    return clip(level, values.reshape(-1), (space.low.reshape(-1), space.high.reshape(-1)),
                world, scale)  # fmt: skip


def clip(level: str, values, bounds: tuple, world=None, scale="physical") -> np.ndarray:
    """A checked Box action (its values, flat) clipped to `bounds` (the space's low and high,
    flat), in physical units, as `validate` returns it."""
    out = actions.clip(np.asarray(values, dtype=np.float64), *bounds)
    return actions.to_physical(level, world, out) if scale == "normalized" else out
