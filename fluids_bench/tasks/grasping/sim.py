"""The grasping-in-clutter world (source ch. 6, a Box2D arm there), on pymunk 7.

A top-down table in metres, x to the right and y away from the arm; the table spans
`[-width/2, width/2] × [0, depth]` and the arm's base sits on its near edge at (0, 0). The arm
has three revolute joints (relative angles `q`, link lengths `links`) and a parallel-jaw
gripper whose opening is `g` in [0, 1] (0 open, 1 closed). The controlled point, the *end
effector*, is the grasp centre: `grasp_offset` metres ahead of the palm, between the fingers.

Physics: objects are dynamic boxes in a space with no gravity and `damping = 0`, so they move
only while pushed (quasi-static pushing, as in gym-pusht). Links, palm and fingers are kinematic
bodies: each substep they are given the velocity that carries them exactly onto the arm's
forward kinematics at the end of the substep, so they push objects and are never pushed back.
An object whose centre leaves the table is knocked off: it is removed from the space and
counted once.

The state that matters is the poses (objects' velocities are zeroed every substep), so
`GraspWorld.from_state` rebuilds a world from them; it continues like the live one up to
pymunk's contact cache (warm starting), i.e. to ~1e-5 m, which is what the supervisor's
foresight needs. Exact copies come from replay: a world remembers its initial state and the
commands it executed, and pickling stores those and replays them (fresh builds replay
bit-identically), so an unpickled world continues exactly as the original.

Controller (the source's "Jacobian transpose controller for the 3 main joints"): a commanded
end-effector velocity `v` moves the joints by a few Jacobian-transpose steps `Δq = α Jᵀ e`
toward `p + v dt`; the arm's redundant degree of freedom (the null space of `J`) makes
the gripper trail its motion like a caster (see `arm_step`); joint speeds are scaled down
to `joint_speed` and joint angles clipped to `joint_limits`.

This module imports neither gymnasium nor another task.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
import pymunk
from pymunk import _chipmunk

from fluids_bench.core.validation import check_float, check_int, fail
from fluids_bench.tasks.grasping.kernels import arm_step_kernel, inverse_kernel

JT_ITERATIONS = 6  # Jacobian-transpose iterations per env step (end effector within ~5%)
N_OBJECTS = 6  # the target (index 0) and five obstacles
TARGET = 0
SCENE_ATTEMPTS = 100  # whole-scene redraws before giving up (the first nearly always fits)

# pymunk's property setters, called directly: Body's attribute assignment goes through a typing
# mixin's __setattr__ that costs more than the setter itself, ~20 times per step
_SET_POSITION = pymunk.Body.position.fset
_SET_ANGLE = pymunk.Body.angle.fset
_SET_VELOCITY = pymunk.Body.velocity.fset
_SET_ANGULAR_VELOCITY = pymunk.Body.angular_velocity.fset
_CP_SPACE_STEP = _chipmunk.lib.cpSpaceStep  # what Space.step calls (pymunk 7, non-threaded)

# collision categories: objects collide with everything, arm parts only with objects
_OBJECT_CAT, _ARM_CAT = 0b01, 0b10


@dataclass(frozen=True)
class GraspConfig:
    """Geometry, scene distribution and control limits (SI units: m, rad, s)."""

    table_width: float = 0.70
    table_depth: float = 0.60
    links: tuple[float, float, float] = (0.28, 0.24, 0.05)
    link_radius: float = 0.012
    grasp_offset: float = 0.045  # grasp centre ahead of the palm
    finger_length: float = 0.07
    finger_radius: float = 0.006
    gap_open: float = 0.095  # between the fingers' inner surfaces
    gap_closed: float = 0.0
    # joint limits of the relative angles q1 (shoulder), q2 (elbow), q3 (wrist)
    joint_limits: tuple[tuple[float, float], ...] = ((0.0, math.pi), (-2.9, 2.9), (-2.2, 2.2))
    joint_speed: float = 3.0  # rad/s per joint
    max_speed: float = 0.25  # m/s of the end effector at |action| = 1
    turn_rate: float = 5.0  # rad/s of the gripper's heading
    caster_length: float = 0.04  # m of travel over which the heading error falls by 1/e
    close_time: float = 0.4  # s from fully open to fully closed
    dt: float = 0.1  # s per env step
    substeps: int = 5
    # scene: the target's nominal centre; its offset ~ N(0, (target_std_frac * width)^2 I)
    target_nominal: tuple[float, float] = (0.0, 0.44)
    target_std_frac: float = 0.03
    object_size: tuple[float, float] = (0.040, 0.055)  # box side range
    target_size: float = 0.045
    obstacle_radius: tuple[float, float] = (0.085, 0.15)  # obstacle centre distance to target
    edge_margin: float = 0.03  # objects start this far inside the table
    friction: float = 0.5
    home: tuple[float, float, float] = (0.0, 0.22, math.pi / 2)  # end-effector x, y, heading

    def __post_init__(self) -> None:
        where = "GraspConfig"
        for name in (
            "table_width",
            "table_depth",
            "dt",
            "max_speed",
            "turn_rate",
            "caster_length",
            "close_time",
        ):
            check_float(where, name, getattr(self, name), 0.0, lo_open=True)
        check_float(where, "target_std_frac", self.target_std_frac, 0.0, 0.2)
        check_int(where, "substeps", self.substeps, 1, 100)
        if len(self.links) != 3 or min(self.links) <= 0:
            fail(where, "links", self.links, "three positive lengths")
        if not 0.0 <= self.gap_closed < self.gap_open:
            fail(where, "gap_closed", self.gap_closed, f"[0, gap_open={self.gap_open})")

    @property
    def reach(self) -> float:
        return sum(self.links) + self.grasp_offset

    @functools.cached_property
    def kernel_params(self) -> np.ndarray:
        """The controller's parameters as the compiled kernel reads them (see kernels.py)."""
        limits = np.asarray(self.joint_limits, dtype=np.float64).reshape(-1)
        return np.array(
            [
                *self.links,
                self.grasp_offset,
                *limits,
                self.joint_speed,
                self.max_speed,
                self.turn_rate,
                self.caster_length,
                self.dt,
                JT_ITERATIONS,
            ],
            dtype=np.float64,
        )


# -- kinematics (plain floats: three joints are cheaper in math than in numpy) --------------


def forward(cfg: GraspConfig, q) -> tuple[list[tuple[float, float]], float]:
    """Joint points `[base, elbow, wrist, palm, grasp centre]` and the gripper heading."""
    l1, l2, l3 = cfg.links
    t1 = q[0]
    t2 = t1 + q[1]
    t3 = t2 + q[2]
    x1, y1 = l1 * math.cos(t1), l1 * math.sin(t1)
    x2, y2 = x1 + l2 * math.cos(t2), y1 + l2 * math.sin(t2)
    c3, s3 = math.cos(t3), math.sin(t3)
    x3, y3 = x2 + l3 * c3, y2 + l3 * s3
    xe, ye = x3 + cfg.grasp_offset * c3, y3 + cfg.grasp_offset * s3
    return [(0.0, 0.0), (x1, y1), (x2, y2), (x3, y3), (xe, ye)], t3


def jacobian(points: list[tuple[float, float]]) -> tuple[list[float], list[float]]:
    """2×3 Jacobian of the grasp centre (two rows): column i is ẑ × (p − joint_i)."""
    xe, ye = points[4]
    return (
        [-(ye - points[0][1]), -(ye - points[1][1]), -(ye - points[2][1])],
        [xe - points[0][0], xe - points[1][0], xe - points[2][0]],
    )


def inverse(cfg: GraspConfig, x: float, y: float, heading: float, elbow: float = -1.0):
    """Joint angles putting the grasp centre at (x, y) with the given heading, or None.

    `elbow` picks the elbow branch (the sign of q2). Joint limits are not checked. The
    arithmetic is the compiled controller's (`inverse_kernel` in
    `fluids_bench.tasks.grasping.kernels`), so planner and controller agree on every reachable pose."""
    out = np.empty(3)
    if not inverse_kernel(cfg.kernel_params, float(x), float(y), float(heading), float(elbow), out):
        return None
    return out.tolist()


def within_limits(cfg: GraspConfig, q) -> bool:
    return all(lo <= a <= hi for a, (lo, hi) in zip(q, cfg.joint_limits, strict=True))


def wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def arm_step(cfg: GraspConfig, q, velocity) -> list[float]:
    """Joint angles after one env step of commanded end-effector `velocity` (m/s).

    1. Jacobian transpose: `JT_ITERATIONS` steps `Δq = α Jᵀ e` toward the displaced end
       effector `p + v dt` (`e` the remaining error, `α` the optimal step along `J Jᵀ e`;
       a joint that reaches a limit drops out); this gives its new position.
    2. The arm's one redundant degree of freedom (the null space of `J`) sets the gripper's
       heading, resolved exactly by inverse kinematics at that position: the gripper trails
       its motion like a caster, turning toward the direction of motion by the fraction
       `1 - exp(-distance / caster_length)` of the error (at most `turn_rate` per second),
       and holds its heading when the motion points backwards (more than 120° off).
    3. Joint speeds are scaled down to `joint_speed`, then angles clipped to `joint_limits`,
       and the whole step scaled down if the end effector would move faster than `max_speed`.

    Compiled (`fluids_bench.tasks.grasping.kernels`): it runs every step of the env and of
    the supervisor's foresight.
    """
    out = arm_step_kernel(
        cfg.kernel_params, np.asarray(q, dtype=np.float64), float(velocity[0]), float(velocity[1])
    )
    return [float(out[0]), float(out[1]), float(out[2])]


# -- objects -----------------------------------------------------------------------------------


def box_vertices(width: float, height: float) -> np.ndarray:
    w, h = width / 2, height / 2
    return np.array([(-w, -h), (w, -h), (w, h), (-w, h)])


@dataclass
class WorldState:
    """Everything the world's future depends on (poses; velocities are zeroed every substep)."""

    sizes: np.ndarray  # (6, 2) box sides
    poses: np.ndarray  # (6, 3) x, y, rotation
    on_table: np.ndarray  # (6,) bool
    q: np.ndarray  # (3,)
    gripper: float
    knocked: int = 0
    grasped: bool = False
    steps: int = 0

    def copy(self) -> WorldState:
        return WorldState(
            self.sizes.copy(),
            self.poses.copy(),
            self.on_table.copy(),
            self.q.copy(),
            self.gripper,
            self.knocked,
            self.grasped,
            self.steps,
        )


def sample_scene(
    cfg: GraspConfig, rng: np.random.Generator, layout_seed: int | None = None
) -> WorldState:
    """Target around its nominal pose (isotropic Gaussian), five obstacles around the target.

    Obstacles are placed by rejection: a uniform bearing and a distance in
    `obstacle_radius` from the target, no overlap (bounding circles), on the table by
    `edge_margin`. Everything is drawn from `rng`.

    With `layout_seed`, the obstacles and the target's rotation are a fixed layout drawn
    from that seed around the nominal pose, and only the target's position offset comes from
    `rng` (redrawn while the target would overlap an obstacle): the source's protocol, which
    resampled the target's pose in one scene.
    """
    std = cfg.target_std_frac * cfg.table_width
    sizes = np.empty((N_OBJECTS, 2))
    poses = np.empty((N_OBJECTS, 3))
    sizes[TARGET] = cfg.target_size
    # A target drawn near the table's edge may leave no room for large obstacles: then the
    # whole scene is drawn again (the first draw, which almost always fits, is unchanged).
    for attempt in range(SCENE_ATTEMPTS):
        if layout_seed is None:
            poses[TARGET, :2] = np.asarray(cfg.target_nominal) + std * rng.standard_normal(2)
            poses[TARGET, 2] = rng.uniform(-math.pi / 4, math.pi / 4)
            placed = _place_obstacles(cfg, rng, sizes, poses)
        else:
            layout = np.random.default_rng([layout_seed, attempt] if attempt else layout_seed)
            poses[TARGET, :2] = cfg.target_nominal
            poses[TARGET, 2] = layout.uniform(-math.pi / 4, math.pi / 4)
            placed = _place_obstacles(cfg, layout, sizes, poses)
        if placed:
            break
    else:
        raise RuntimeError(
            f"sample_scene: no room for the obstacles around the target in {SCENE_ATTEMPTS} "
            f"scenes (object_size {cfg.object_size} m, obstacle_radius {cfg.obstacle_radius} m)"
        )
    if layout_seed is not None:
        radii = np.hypot(sizes[:, 0], sizes[:, 1]) / 2
        for _ in range(1000):
            xy = np.asarray(cfg.target_nominal) + std * rng.standard_normal(2)
            gaps = np.hypot(*(poses[1:, :2] - xy).T) - radii[1:] - radii[TARGET]
            if gaps.min() > 0.005:
                break
        poses[TARGET, :2] = xy
    hx, hy, hh = cfg.home
    q = inverse(cfg, hx, hy, hh)
    assert q is not None and within_limits(cfg, q)
    return WorldState(sizes, poses, np.ones(N_OBJECTS, bool), np.array(q), 0.0)


def _place_obstacles(
    cfg: GraspConfig, rng: np.random.Generator, sizes: np.ndarray, poses: np.ndarray
) -> bool:
    """Place the obstacles by rejection; False where one finds no room in 1,000 draws."""
    radii = [math.hypot(*sizes[TARGET]) / 2]
    for i in range(1, N_OBJECTS):
        for _ in range(1000):
            side = rng.uniform(*cfg.object_size, size=2)
            bearing = rng.uniform(-math.pi, math.pi)
            dist = rng.uniform(*cfg.obstacle_radius)
            x = poses[TARGET, 0] + dist * math.cos(bearing)
            y = poses[TARGET, 1] + dist * math.sin(bearing)
            r = math.hypot(*side) / 2
            if not _on_table(cfg, x, y, cfg.edge_margin + r * 0.5):
                continue
            if math.hypot(x - cfg.home[0], y - cfg.home[1]) < r + 0.08:  # clear of the gripper
                continue
            if any(
                math.hypot(x - poses[j, 0], y - poses[j, 1]) < r + radii[j] + 0.005
                for j in range(i)
            ):
                continue
            break
        else:
            return False
        sizes[i] = side
        poses[i] = (x, y, rng.uniform(-math.pi / 4, math.pi / 4))
        radii.append(r)
    return True


def _on_table(cfg: GraspConfig, x: float, y: float, margin: float = 0.0) -> bool:
    half = cfg.table_width / 2 - margin
    return -half <= x <= half and margin <= y <= cfg.table_depth - margin


# -- the world ---------------------------------------------------------------------------------


@dataclass
class StepEvents:
    """What happened during one step."""

    newly_knocked: int = 0
    grasped: bool = False
    contacts: int = 0


@dataclass
class GraspWorld:
    """A pymunk space with the table's objects and the arm, built from a `WorldState`."""

    cfg: GraspConfig
    state: WorldState
    space: pymunk.Space = field(init=False, repr=False)
    objects: list[pymunk.Body] = field(init=False, repr=False)
    arm: list[pymunk.Body] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.initial = self.state.copy()
        self.commands: list[tuple[float, float, bool]] = []
        self._build()

    @classmethod
    def from_state(cls, cfg: GraspConfig, state: WorldState) -> GraspWorld:
        return cls(cfg, state.copy())

    # pickling stores the initial state and the commands, and replays them (exact)
    def __getstate__(self) -> dict:
        return {"cfg": self.cfg, "initial": self.initial.copy(), "commands": list(self.commands)}

    def __setstate__(self, data: dict) -> None:
        self.cfg = data["cfg"]
        self.state = data["initial"]
        self.__post_init__()
        for command in data["commands"]:
            self.step(*command)

    def _build(self) -> None:
        cfg, st = self.cfg, self.state
        space = pymunk.Space()
        space.damping = 0.0  # quasi-static: objects stop the moment nothing pushes them
        space.iterations = 10
        self.objects = []
        for i in range(N_OBJECTS):
            verts = box_vertices(*st.sizes[i])
            mass = 0.1
            body = pymunk.Body(mass, pymunk.moment_for_poly(mass, verts.tolist()))
            body.position = (float(st.poses[i, 0]), float(st.poses[i, 1]))
            body.angle = float(st.poses[i, 2])
            shape = pymunk.Poly(body, verts.tolist())
            shape.friction = cfg.friction
            shape.filter = pymunk.ShapeFilter(categories=_OBJECT_CAT)
            self.objects.append(body)
            if st.on_table[i]:
                space.add(body, shape)
        arm_filter = pymunk.ShapeFilter(categories=_ARM_CAT, mask=_OBJECT_CAT)
        self.arm = []
        l1, l2, l3 = cfg.links
        half_palm = cfg.gap_open / 2 + 2 * cfg.finger_radius
        parts = [
            [((0.0, 0.0), (l1, 0.0), cfg.link_radius)],
            [((0.0, 0.0), (l2, 0.0), cfg.link_radius)],
            [
                ((0.0, 0.0), (l3, 0.0), cfg.link_radius),
                ((l3, -half_palm), (l3, half_palm), cfg.finger_radius),
            ],
            [((0.0, 0.0), (cfg.finger_length, 0.0), cfg.finger_radius)],
            [((0.0, 0.0), (cfg.finger_length, 0.0), cfg.finger_radius)],
        ]
        for segments in parts:
            body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            shapes = []
            for a, b, r in segments:
                s = pymunk.Segment(body, a, b, r)
                s.friction = cfg.friction
                s.filter = arm_filter
                shapes.append(s)
            space.add(body, *shapes)
            self.arm.append(body)
        self.space = space
        self._place_arm(st.q, st.gripper)

    # -- arm poses ---------------------------------------------------------------------------

    def gap(self, gripper: float) -> float:
        return self.cfg.gap_open - gripper * (self.cfg.gap_open - self.cfg.gap_closed)

    def arm_poses(self, q, gripper: float) -> list[tuple[float, float, float]]:
        """(x, y, angle) of the five arm bodies: three links, left and right finger."""
        cfg = self.cfg
        pts, heading = forward(cfg, q)
        t1 = q[0]
        t2 = t1 + q[1]
        c, s = math.cos(heading), math.sin(heading)
        off = self.gap(gripper) / 2 + cfg.finger_radius
        px, py = pts[3]
        return [
            (0.0, 0.0, t1),
            (pts[1][0], pts[1][1], t2),
            (pts[2][0], pts[2][1], heading),
            (px - s * off, py + c * off, heading),
            (px + s * off, py - c * off, heading),
        ]

    def _place_arm(self, q, gripper: float, poses=None) -> None:
        self._arm_pose = self.arm_poses(q, gripper) if poses is None else poses
        for body, (x, y, a) in zip(self.arm, self._arm_pose, strict=True):
            _SET_POSITION(body, (x, y))
            _SET_ANGLE(body, a)

    # -- queries -----------------------------------------------------------------------------

    def sync(self) -> None:
        """Copy the objects' poses from the bodies into `state`."""
        poses = self.state.poses
        for i, body in enumerate(self.objects):
            if self.state.on_table[i]:
                x, y = body.position
                poses[i, 0], poses[i, 1], poses[i, 2] = x, y, body.angle

    def end_effector(self) -> tuple[float, float, float]:
        pts, heading = forward(self.cfg, self.state.q)
        return pts[4][0], pts[4][1], heading

    def between_fingers(self, gripper: float | None = None) -> list[tuple[int, float]]:
        """Objects on the table whose centre lies between the fingers, with the jaw gap at
        which the fingers touch each (twice its largest lateral reach from the gripper axis)."""
        cfg, st = self.cfg, self.state
        g = st.gripper if gripper is None else gripper
        pts, heading = forward(cfg, st.q)
        px, py = pts[3]
        c, s = math.cos(heading), math.sin(heading)
        half = self.gap(g) / 2
        out = []
        for i in range(N_OBJECTS):
            if not st.on_table[i]:
                continue
            dx, dy = st.poses[i, 0] - px, st.poses[i, 1] - py
            u, v = dx * c + dy * s, -dx * s + dy * c
            if not (0.0 <= u <= cfg.finger_length and abs(v) <= half):
                continue
            rot = st.poses[i, 2] - heading
            verts = box_vertices(*st.sizes[i])
            lateral = v + verts[:, 0] * math.sin(rot) + verts[:, 1] * math.cos(rot)
            out.append((i, 2.0 * float(np.max(np.abs(lateral)))))
        return out

    def grasp_holds(self, close: bool) -> bool:
        """The grasp predicate: the gripper is commanded closed, the target's centre lies between
        the fingers and the fingers have closed onto it (it is what stops them)."""
        if not close or not self.state.on_table[TARGET]:
            return False
        inside = self.between_fingers()
        if not inside:
            return False
        widest = max(inside, key=lambda t: t[1])
        return widest[0] == TARGET and self.gap(self.state.gripper) <= widest[1] + 1e-3

    def gripper_stop(self) -> float:
        """The closest the gripper can close (g) before touching what is between the fingers."""
        inside = self.between_fingers()
        if not inside:
            return 1.0
        width = max(w for _, w in inside)
        cfg = self.cfg
        return min(1.0, max(0.0, (cfg.gap_open - width) / (cfg.gap_open - cfg.gap_closed)))

    # -- dynamics ----------------------------------------------------------------------------

    def step(self, vx: float, vy: float, close: bool) -> StepEvents:
        """Advance one env step with end-effector velocity command (vx, vy) in m/s."""
        cfg, st = self.cfg, self.state
        self.commands.append((vx, vy, close))
        q0 = st.q.copy()
        q1 = np.array(arm_step(cfg, q0, (vx, vy)))
        g0 = st.gripper
        rate = cfg.dt / cfg.close_time
        if close:
            g1 = min(g0 + rate, max(g0, self.gripper_stop()))
        else:
            g1 = max(0.0, g0 - rate)
        # each arm body moves at constant velocity from its pose to the commanded one over the
        # step's substeps: a chord of its arc, ~0.1 mm off at typical joint steps (3 mm at
        # full joint speed), and the arm lands exactly on its kinematics at the step's end
        inv = 1.0 / cfg.dt
        arm1 = self.arm_poses(q1, g1)
        for body, (x0, y0, a0), (x1, y1, a1) in zip(self.arm, self._arm_pose, arm1, strict=True):
            _SET_VELOCITY(body, ((x1 - x0) * inv, (y1 - y0) * inv))
            _SET_ANGULAR_VELOCITY(body, (a1 - a0) * inv)
        h = cfg.dt / cfg.substeps
        # the first substep through pymunk's Space.step (its bookkeeping: new bodies' mass
        # checks, deferred adds and removes, post-step callbacks, none of which the later
        # substeps can create here: no collision callbacks), the rest straight into Chipmunk
        self.space.step(h)
        for _ in range(cfg.substeps - 1):
            _CP_SPACE_STEP(self.space._space, h)
        # land the arm exactly on the commanded pose (no floating-point drift)
        self._place_arm(q1, g1, arm1)
        st.q = q1
        st.gripper = g1
        st.steps += 1
        self.sync()
        events = StepEvents()
        for i, body in enumerate(self.objects):
            if st.on_table[i] and not _on_table(cfg, st.poses[i, 0], st.poses[i, 1]):
                st.on_table[i] = False
                self.space.remove(body, *body.shapes)
                st.knocked += 1
                events.newly_knocked += 1
        if not st.grasped and self.grasp_holds(close):
            st.grasped = True
            events.grasped = True
        return events

    # -- cost (source ch. 6) -----------------------------------------------------------------

    def cost(self) -> int:
        """Objects knocked off + 10 × (target not grasped)."""
        return self.state.knocked + (0 if self.state.grasped else 10)
