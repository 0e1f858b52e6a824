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


def action_space(level: str, world: World, waypoints: int) -> spaces.Space:
    if level == "behavior":
        return spaces.Discrete(movement_count(world))
    if level == "trajectory":
        return spaces.Box(-50.0, 50.0, (2 * waypoints,), np.float32)
    if level == "velocity":
        return spaces.Box(0.0, world.scene.car.max_speed, (1,), np.float32)
    return spaces.Box(-1.0, 1.0, (2,), np.float32)


def validate(level: str, space: spaces.Space, action: Any, where: str):
    """``action`` as the env uses it; ValueError naming the level, what is wrong and what is
    allowed (the suite's shared check, :func:`fluids_bench.core.actions.check_action`). Box
    actions must be real numbers of exactly the space's shape (strings, bools and complex
    numbers are refused, never coerced; ``(1, n)`` is not ``(n,)``); out of bounds they are
    clipped; NaN and infinities are refused."""
    if level == "behavior":
        return check_discrete_action(where, space, action, "behavior action")
    values = check_box_action(where, space, action, f"{level} action").tolist()
    low, high = space.low.reshape(-1).tolist(), space.high.reshape(-1).tolist()
    return np.array([min(max(v, lo), hi) for v, lo, hi in zip(values, low, high, strict=True)])


def label(supervisor: DrivingSupervisor, world: World, level: str, agent: int):
    """The supervisor's label for ``agent`` at ``level``, typed like an action of that level."""
    value = supervisor.label(world, level, agent)
    if level == "behavior":
        return int(value)
    if level == "velocity":
        return np.array([value], dtype=np.float32)
    return np.asarray(value, dtype=np.float32)


def waypoints_aim(
    world: World, supervisor: DrivingSupervisor, agent: int, waypoints: np.ndarray
) -> np.ndarray:
    """The world-frame point car ``agent`` steers to for trajectory-level ``waypoints`` (its
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
    """Every agent's controls with the ``chosen`` agents' (validated) actions at ``level``, the
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
