"""Per-task controls: what a person's keys, mouse or gamepad mean as an action of the env.

The mapping from input state to action is a set of small pure functions (tested without a
window); a `Scheme` ties one of them to an env and says which input completes a label
in the relabelling tool. `scheme_for` picks the scheme of an env, or raises ValueError
for an env no person can act in here.

Input state is an `Inputs`: the key names held (`"left"`, `"right"`, `"up"`,
`"down"`, `"space"`, `"shift"`), the mouse position in frame pixels `(u, v)` (`u`
east, `v` south, as `fluids_bench.core.raster`), the mouse buttons held (left, middle,
right) and the joystick's axes in [-1, 1] (axis 0 right positive, axis 1 down positive, as
pygame reports them).

The schemes:

* GridWorld: arrow keys move (left, right, up = forward y + 1, down = backward); space stays.
  In teleop no key held also stays.
* DrivingTrack: left / right turn 15 degrees, up (or nothing held, in teleop) goes straight.
* FLUIDS at the control level: left / right steer (half lock; with shift full lock), up
  accelerates, down brakes; a gamepad's left stick steers (axis 0) and its vertical axis
  accelerates (up) or brakes (down). At the velocity level: up / down change the target
  speed by 1 m/s per press, the digits 0-9 set it to that tenth of the maximum speed, the
  stick's vertical axis sets it (up = faster). Return confirms a relabel.
* Singulation: while the left button is held, the fingertip moves toward the mouse (the
  largest joint change per step, in rotation and extension, toward the pointer's pose).
* GraspingInClutter: while the left button is held, the gripper moves toward the mouse at up
  to full speed; the right button (or space) held closes the jaws.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

KEY_NAMES = ("left", "right", "up", "down", "space", "shift", "return") + tuple("0123456789")


@dataclass(frozen=True)
class Inputs:
    """A snapshot of what the person holds (see the module docstring for the conventions)."""

    keys: frozenset[str] = frozenset()
    mouse: tuple[float, float] | None = None
    buttons: tuple[bool, bool, bool] = (False, False, False)
    axes: tuple[float, ...] = ()

    def with_keys(self, keys: Iterable[str]) -> Inputs:
        return Inputs(frozenset(keys), self.mouse, self.buttons, self.axes)


# -- pure functions: input state -> action ---------------------------------------------------

GRID_LEFT, GRID_RIGHT, GRID_FORWARD, GRID_BACKWARD, GRID_STAY = range(5)


def gridworld_action(keys: frozenset[str]) -> int | None:
    """GridWorld's move for the held keys (the first of left, right, up, down, space), or
    None when none is held."""
    for name, action in (
        ("left", GRID_LEFT),
        ("right", GRID_RIGHT),
        ("up", GRID_FORWARD),
        ("down", GRID_BACKWARD),
        ("space", GRID_STAY),
    ):
        if name in keys:
            return action
    return None


TRACK_RIGHT, TRACK_STRAIGHT, TRACK_LEFT = 0, 1, 2  # heading change -15, 0, +15 degrees


def track_action(keys: frozenset[str]) -> int | None:
    """DrivingTrack's turn for the held keys (left or right; up is straight), None if none."""
    if "left" in keys and "right" not in keys:
        return TRACK_LEFT
    if "right" in keys and "left" not in keys:
        return TRACK_RIGHT
    if "up" in keys:
        return TRACK_STRAIGHT
    return None


KEY_STEER = 0.5  # normalised steering of an arrow key (shift: full lock)
DEAD_ZONE = 0.08  # joystick axis magnitudes below this read as 0


def _axis(axes: tuple[float, ...], i: int) -> float:
    value = float(axes[i]) if len(axes) > i else 0.0
    return 0.0 if abs(value) < DEAD_ZONE else max(-1.0, min(1.0, value))


def fluids_control_action(keys: frozenset[str], axes: tuple[float, ...] = ()) -> np.ndarray:
    """FLUIDS' control-level `[steer, force]` in [-1, 1]: positive steer turns left.

    Keys: left / right steer by `KEY_STEER` (1 with shift), up accelerates (+1), down
    brakes (-1). A joystick's stick, when off its dead zone, adds to them: axis 0 steers
    (pushed right = steer right), axis 1 accelerates when pushed up and brakes when down."""
    steer = KEY_STEER * (1.0 + ("shift" in keys)) * (("left" in keys) - ("right" in keys))
    force = float(("up" in keys) - ("down" in keys))
    steer -= _axis(axes, 0)
    force -= _axis(axes, 1)
    return np.clip(np.array([steer, force], dtype=np.float32), -1.0, 1.0)


SPEED_STEP = 1.0  # m/s per up / down press at the velocity level


def fluids_velocity_target(target: float, key: str | None, v_max: float) -> float:
    """The target speed after pressing `key` (up / down: ±1 m/s, a digit d: d / 9 of
    `v_max`; anything else leaves it), clipped to [0, v_max]."""
    if key == "up":
        target += SPEED_STEP
    elif key == "down":
        target -= SPEED_STEP
    elif key is not None and len(key) == 1 and key.isdigit():
        target = int(key) / 9.0 * v_max
    return min(max(target, 0.0), v_max)


def fluids_velocity_from_stick(axes: tuple[float, ...], v_max: float) -> float | None:
    """Target speed from a stick's vertical axis (pushed up = faster), None at rest."""
    value = _axis(axes, 1)
    return None if value == 0.0 else max(0.0, -value) * v_max


def pixel_to_world(u: float, v: float, ppm: float, x0: float, y1: float) -> tuple[float, float]:
    """World (x, y) in m at frame pixel (u, v): the inverse of
    `fluids_bench.core.raster.pixel_affine` (top-left corner at world (x0, y1))."""
    return x0 + (u + 0.5) / ppm, y1 - (v + 0.5) / ppm


def singulation_action(
    target: tuple[float, float] | None,
    theta: float,
    r: float,
    max_dtheta: float,
    max_dr: float,
) -> np.ndarray:
    """`[a_rot, a_ext]` moving the fingertip at pose (theta rad, r m) toward the world point
    `target` (m) as far as one step allows; zeros when `target` is None (hold still)."""
    if target is None:
        return np.zeros(2, dtype=np.float32)
    x, y = target
    theta_t, r_t = math.atan2(y, x), math.hypot(x, y)
    return np.clip(
        np.array([(theta_t - theta) / max_dtheta, (r_t - r) / max_dr], dtype=np.float32), -1, 1
    )


def grasping_action(
    target: tuple[float, float] | None,
    gripper_xy: tuple[float, float],
    close: bool,
    step_length: float,
) -> np.ndarray:
    """`[vx, vy, grip]`: toward the world point `target` at full speed, slowing within one
    step (`step_length` = max speed × dt, m) of it; zero velocity when `target` is None;
    grip 1 (close) or 0 (open)."""
    grip = 1.0 if close else 0.0
    if target is None:
        return np.array([0.0, 0.0, grip], dtype=np.float32)
    d = np.array([target[0] - gripper_xy[0], target[1] - gripper_xy[1]])
    distance = float(np.hypot(*d))
    if distance < 1e-9:
        return np.array([0.0, 0.0, grip], dtype=np.float32)
    v = d / distance * min(1.0, distance / step_length)
    return np.array([v[0], v[1], grip], dtype=np.float32)


# -- schemes: a pure function bound to an env -------------------------------------------------


@dataclass
class Scheme:
    """How a person acts in one env: `action(inputs)` for the env's current state.

    `fps` is the teleop step rate; `help` lists the controls (shown in the window);
    `confirm_keys` / `confirm_click` say which key presses or mouse clicks complete a label
    in the relabelling tool (Return always does)."""

    name: str
    env: Any  # the unwrapped env
    fps: float
    help: tuple[str, ...]
    confirm_keys: frozenset[str] = frozenset()
    confirm_click: bool = False
    action_names: tuple[str, ...] = ()  # Discrete actions' names, for the window
    memory: dict[str, Any] = field(default_factory=dict)

    def reset(self) -> None:
        """Forget what the scheme carried over (a velocity target) at an episode's start."""
        self.memory.clear()

    def key_pressed(self, key: str) -> None:
        """A key went down (stateful schemes update their memory here)."""

    def action(self, inputs: Inputs) -> Any:
        raise NotImplementedError


class GridWorldScheme(Scheme):
    def action(self, inputs: Inputs) -> Any:
        a = gridworld_action(inputs.keys)
        return np.int64(GRID_STAY if a is None else a)


class TrackScheme(Scheme):
    def action(self, inputs: Inputs) -> Any:
        a = track_action(inputs.keys)
        return np.int64(TRACK_STRAIGHT if a is None else a)


class FluidsControlScheme(Scheme):
    def action(self, inputs: Inputs) -> Any:
        return fluids_control_action(inputs.keys, inputs.axes)


class FluidsVelocityScheme(Scheme):
    @property
    def v_max(self) -> float:
        return float(self.env.action_space.high[0])

    def key_pressed(self, key: str) -> None:
        target = self.memory.get("target", 0.0)
        self.memory["target"] = fluids_velocity_target(target, key, self.v_max)

    def action(self, inputs: Inputs) -> Any:
        stick = fluids_velocity_from_stick(inputs.axes, self.v_max)
        if stick is not None:
            self.memory["target"] = stick
        return np.array([self.memory.get("target", 0.0)], dtype=np.float32)


class SingulationScheme(Scheme):
    def action(self, inputs: Inputs) -> Any:
        from fluids_bench.tasks.singulation import render
        from fluids_bench.tasks.singulation.sim import MAX_DR, MAX_DTHETA

        world = self.env.world
        target = None
        if inputs.mouse is not None and inputs.buttons[0]:
            ppm = self.env.RENDER_SIZE / render.VIEW_SIZE
            target = pixel_to_world(*inputs.mouse, ppm, render.VIEW_X0, render.VIEW_Y1)
        return singulation_action(target, world.theta, world.r, MAX_DTHETA, MAX_DR)


class GraspingScheme(Scheme):
    def action(self, inputs: Inputs) -> Any:
        from fluids_bench.tasks.grasping.render import view

        env = self.env
        target = None
        if inputs.mouse is not None and inputs.buttons[0]:
            affine, ppm = view(env.cfg, env.render_size)
            # pixel_affine's inverse: x0 and y1 from its translation column
            x0 = -(affine[0, 2] + 0.5) / ppm
            y1 = (affine[1, 2] + 0.5) / ppm
            target = pixel_to_world(*inputs.mouse, ppm, x0, y1)
        x, y, _ = env.world.end_effector()
        close = inputs.buttons[2] or "space" in inputs.keys
        return grasping_action(target, (x, y), close, env.cfg.max_speed * env.cfg.dt)


ARROWS = frozenset({"left", "right", "up", "down"})


def scheme_for(env: Any) -> Scheme:
    """The control scheme of `env` (wrapped or not); ValueError for an env without one."""
    base = getattr(env, "unwrapped", env)
    cls = type(base).__name__
    env_id = base.spec.id if getattr(base, "spec", None) is not None else cls
    if cls == "GridWorldEnv":
        return GridWorldScheme(
            "gridworld (arrow keys)",
            base,
            4.0,
            ("arrows: move", "space: stay"),
            confirm_keys=ARROWS | {"space"},
            action_names=("left", "right", "forward", "backward", "stay"),
        )
    if cls == "DrivingTrackEnv":
        return TrackScheme(
            "driving track (left / straight / right)",
            base,
            5.0,
            ("left/right: turn 15 deg", "up: straight"),
            confirm_keys=frozenset({"left", "right", "up"}),
            action_names=("right", "straight", "left"),
        )
    if cls == "FluidsEnv":
        level = base.action_level
        if level == "control":
            return FluidsControlScheme(
                "FLUIDS control (keyboard or gamepad)",
                base,
                10.0,
                ("left/right: steer (shift: full)", "up: throttle  down: brake", "pad: stick"),
            )
        if level == "velocity":
            return FluidsVelocityScheme(
                "FLUIDS velocity (target speed)",
                base,
                10.0,
                ("up/down: target speed +-1 m/s", "0-9: tenths of max speed", "pad: stick"),
            )
        raise ValueError(
            f"teleop: {env_id} acts at action_level={level!r}, which has no teleop mapping; "
            "allowed: action_level 'control' or 'velocity' (--env-kwarg action_level=control)"
        )
    if cls == "SingulationEnv":
        return SingulationScheme(
            "singulation (mouse)",
            base,
            10.0,
            ("hold left button: tip to pointer",),
            confirm_click=True,
        )
    if cls == "GraspingInClutterEnv":
        return GraspingScheme(
            "grasping (mouse)",
            base,
            10.0,
            ("hold left: move to pointer", "hold right/space: close jaws"),
            confirm_click=True,
        )
    raise ValueError(
        f"teleop: {env_id} has no teleop mapping; allowed: the ids of {', '.join(TELEOP_FAMILIES)}"
    )


TELEOP_FAMILIES = ("FLUIDS", "GridWorld", "DrivingTrack", "Singulation", "GraspingInClutter")
TELEOP_CLASSES = (
    "FluidsEnv",
    "GridWorldEnv",
    "DrivingTrackEnv",
    "SingulationEnv",
    "GraspingInClutterEnv",
)


def check_teleop_id(env_id: str) -> None:
    """ValueError for an unknown id or one whose env class has no teleop scheme (checked from
    the registration, before building the env)."""
    import gymnasium as gym

    import fluids_bench  # noqa: F401  (registers the ids)

    if env_id not in gym.registry:
        teleop_ids = sorted(
            k
            for k, spec in gym.registry.items()
            if isinstance(spec.entry_point, str)
            and spec.entry_point.rsplit(":", 1)[-1] in TELEOP_CLASSES
        )
        raise ValueError(f"unknown env id {env_id!r}; ids with a teleop mapping: {teleop_ids}")
    entry = gym.registry[env_id].entry_point
    name = entry.rsplit(":", 1)[-1] if isinstance(entry, str) else getattr(entry, "__name__", "")
    if name not in TELEOP_CLASSES:
        raise ValueError(
            f"teleop: {env_id} has no teleop mapping; allowed: the ids of "
            f"{', '.join(TELEOP_FAMILIES)}"
        )
