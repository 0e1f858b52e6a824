"""The singulation world (source ch. 5): a planar arm pushing four polygons on a table (pymunk 7).

Units are SI: metres, radians, seconds. The arm's base is the origin, at the table's near edge;
the table extends towards +y. The arm has two joints, base rotation `theta` (from +x,
counter-clockwise; 90° points straight across the table) and extension `r` (base to
fingertip). Only the fingertip touches the table: the link passes over the objects, as on the
source's robot. The fingertip is a kinematic circle driven by velocity so that the commanded
joint pose is reached at the end of every step (`SUBSTEPS` physics substeps, the fingertip
moving along the commanded joint-space segment).

No gravity and a space damping of 0 make pushing quasi-static: an object moves only while
something pushes it. The four objects are fixed convex polygons of about 10 cm (the source's
four MDF polygons of 4" diameter) with uniform density; `SceneConfig.object_size_scale`
scales them (a sensitivity sweep's factor).

This module imports neither gymnasium nor another task.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import pymunk
import shapely

# pymunk's own C bindings (cffi), called directly in the stepping loop: the Python property and
# ``Space.step`` wrappers cost more than the physics of this small scene (same C calls, same
# results; pymunk is pinned to 7.x)
from pymunk._chipmunk_cffi import lib as _chipmunk

from fluids_bench.core.validation import check_float

DT = 0.1  # s per env step
SUBSTEPS = 10
TIP_RADIUS = 0.01  # m
AREAL_DENSITY = 57.0  # kg/m², 3" of MDF (750 kg/m³)
FRICTION_OBJECTS = 0.5
FRICTION_TIP = 0.5
SINGULATION_DISTANCE = 0.10  # m between centres
# "exactly 10 cm" must count whatever float arithmetic produced the centres
SUCCESS_TOLERANCE = 1e-9
TOUCH_GAP = 2e-4  # m left between objects packed "touching" (below pymunk's slop)
MAX_DTHETA = math.radians(1.5)  # per step
MAX_DR = 0.01  # m per step
NUM_OBJECTS = 4


def _centred(vertices: list[tuple[float, float]]) -> np.ndarray:
    """Vertices (counter-clockwise) moved so the polygon's centroid is the origin."""
    poly = shapely.Polygon(vertices)
    c = poly.centroid
    return np.array(vertices, dtype=np.float64) - [c.x, c.y]


def _regular(n: int, radius: float, squash: float = 1.0, phase: float = 0.0) -> list:
    return [
        (
            radius * math.cos(phase + 2 * math.pi * k / n),
            squash * radius * math.sin(phase + 2 * math.pi * k / n),
        )
        for k in range(n)
    ]


# The four objects: convex polygons of about 10 cm diameter (fixed, like the source's set).
OBJECT_SHAPES: tuple[np.ndarray, ...] = (
    _centred(_regular(5, 0.05)),
    _centred(
        [(0.05, 0.0), (0.025, 0.045), (-0.025, 0.045), (-0.05, 0.0), (-0.03, -0.04), (0.03, -0.04)]
    ),
    _centred([(-0.045, -0.04), (0.05, -0.035), (0.04, 0.045), (-0.04, 0.04)]),
    _centred(_regular(7, 0.05, squash=0.85, phase=0.3)),
)
OBJECT_RADII = np.array([float(np.hypot(*s.T).max()) for s in OBJECT_SHAPES])
OBJECT_SIZE_SCALES = (0.5, 1.5)  # the range of SceneConfig.object_size_scale


@functools.lru_cache(maxsize=32)
def object_shapes(scale: float = 1.0) -> tuple[np.ndarray, ...]:
    """The four objects' vertices (m) with every length multiplied by `scale`; at 1.0 the
    very arrays of `OBJECT_SHAPES` (the nominal world, bit for bit)."""
    if scale == 1.0:
        return OBJECT_SHAPES
    shapes = tuple(shape * scale for shape in OBJECT_SHAPES)
    for shape in shapes:
        shape.setflags(write=False)  # shared by every caller of the cache
    return shapes


@dataclass(frozen=True)
class SceneConfig:
    """Table, arm limits and the initial-state distribution.

    The cluster's translation is `N(cluster_mean, cluster_std² I)` (clipped to
    `cluster_clip` standard deviations so the cluster stays reachable), its rotation uniform
    in `[-cluster_rotation, cluster_rotation]`; each object's own orientation is uniform and
    the objects are packed touching in a random order from random directions.
    """

    table_width: float = 1.0  # m, x in [-w/2, w/2]
    table_depth: float = 0.8  # m, y in [0, depth]
    theta_min: float = math.radians(30.0)
    theta_max: float = math.radians(150.0)
    r_min: float = 0.12
    r_max: float = 0.78
    home_theta: float = math.radians(90.0)
    home_r: float = 0.2
    cluster_mean_x: float = 0.0
    cluster_mean_y: float = 0.45
    # ch. 5: "an isotropic Gaussian with variance of 20cm": read as 20 cm² (std 4.47 cm)
    cluster_std: float = math.sqrt(0.002)
    cluster_clip: float = 3.0
    cluster_rotation: float = math.radians(15.0)
    # perturbations (a sensitivity sweep's factors): 1.0 is the nominal world, bit for bit
    # heaviest object's mass over the lightest's: object i's density × mass_ratio^(i/3 - 1/2)
    # (scaling every mass alike changes nothing here: no gravity, no table friction)
    mass_ratio: float = 1.0
    friction_scale: float = 1.0  # multiplies the objects' and the fingertip's friction
    # every object's lengths × this (density kept, so mass × its square); the singulation
    # distance scales with it (one object size apart), else large objects would start
    # singulated and small ones would have to be thrown apart
    object_size_scale: float = 1.0

    def __post_init__(self) -> None:
        where = "SceneConfig"
        check_float(where, "cluster_std", self.cluster_std, 0.0, 0.2)
        check_float(where, "mass_ratio", self.mass_ratio, 1.0, 100.0)
        check_float(where, "friction_scale", self.friction_scale, 0.0, 4.0)
        check_float(where, "object_size_scale", self.object_size_scale, *OBJECT_SIZE_SCALES)
        check_float(where, "cluster_rotation", self.cluster_rotation, 0.0, math.pi)
        check_float(where, "r_min", self.r_min, 0.0, self.r_max, hi_open=True)
        check_float(where, "theta_min", self.theta_min, 0.0, self.theta_max, hi_open=True)

    @property
    def shapes(self) -> tuple[np.ndarray, ...]:
        """The objects' vertices at this scene's size."""
        return object_shapes(self.object_size_scale)

    @property
    def singulation_distance(self) -> float:
        """Centre distance (m) that counts as singulated: 10 cm × `object_size_scale`."""
        return SINGULATION_DISTANCE * self.object_size_scale


def tip_position(theta: float, r: float) -> tuple[float, float]:
    return r * math.cos(theta), r * math.sin(theta)


def joint_pose(x: float, y: float) -> tuple[float, float]:
    """(theta, r) of a fingertip at (x, y)."""
    return math.atan2(y, x), math.hypot(x, y)


def progress(centres: np.ndarray) -> float:
    """The largest, over objects, of the distance from its centre to the nearest other centre."""
    if len(centres) == NUM_OBJECTS:
        return _progress4(centres[:, 0].tolist(), centres[:, 1].tolist())
    d = np.hypot(*(centres[:, None, :] - centres[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    return float(d.min(axis=1).max())


def _progress4(x: list[float], y: list[float]) -> float:
    """`progress` of four centres, from the six pair distances (the same numbers as the
    all-pairs matrix, a quarter of the cost)."""
    d = np.hypot(
        [x[0] - x[1], x[0] - x[2], x[0] - x[3], x[1] - x[2], x[1] - x[3], x[2] - x[3]],
        [y[0] - y[1], y[0] - y[2], y[0] - y[3], y[1] - y[2], y[1] - y[3], y[2] - y[3]],
    ).tolist()
    # each object's nearest neighbour: pairs (0,1) (0,2) (0,3) | (0,1) (1,2) (1,3) | ...
    return max(
        min(d[0], d[1], d[2]), min(d[0], d[3], d[4]), min(d[1], d[3], d[5]), min(d[2], d[4], d[5])
    )


def is_singulated(centres: np.ndarray, distance: float = SINGULATION_DISTANCE) -> bool:
    """Some object's centre is at least `distance` (10 cm) from every other object's centre."""
    return progress(centres) >= distance - SUCCESS_TOLERANCE


def object_polygon(index: int, x: float, y: float, angle: float, scale: float = 1.0) -> np.ndarray:
    """World vertices (k, 2) of object `index` (its size × `scale`) at pose (x, y, angle)."""
    c, s = math.cos(angle), math.sin(angle)
    v = object_shapes(scale)[index]
    return np.column_stack((x + c * v[:, 0] - s * v[:, 1], y + s * v[:, 0] + c * v[:, 1]))


def sample_cluster(config: SceneConfig, rng: np.random.Generator) -> np.ndarray:
    """Object poses (4, 3) `[x, y, angle]`: packed touching, never already singulated."""
    while True:
        poses = _pack(rng, config.object_size_scale)
        if is_singulated(poses[:, :2], config.singulation_distance):
            continue  # the source's initial states are clusters, never already singulated
        # rotate the cluster about its centroid, then translate it
        spin = rng.uniform(-config.cluster_rotation, config.cluster_rotation)
        shift = rng.standard_normal(2) * config.cluster_std
        shift = np.clip(
            shift,
            -config.cluster_clip * config.cluster_std,
            config.cluster_clip * config.cluster_std,
        )
        centroid = poses[:, :2].mean(axis=0)
        c, s = math.cos(spin), math.sin(spin)
        rel = poses[:, :2] - centroid
        out = poses.copy()
        out[:, 0] = c * rel[:, 0] - s * rel[:, 1] + config.cluster_mean_x + shift[0]
        out[:, 1] = s * rel[:, 0] + c * rel[:, 1] + config.cluster_mean_y + shift[1]
        out[:, 2] = np.mod(poses[:, 2] + spin + math.pi, 2 * math.pi) - math.pi
        return out


def _pack(rng: np.random.Generator, scale: float = 1.0) -> np.ndarray:
    """Place the objects (their size × `scale`) one at a time, in a random order, each slid in
    from a random direction towards the centroid of those already placed until it touches them
    (gap `TOUCH_GAP`)."""
    order = rng.permutation(NUM_OBJECTS)
    angles = rng.uniform(-math.pi, math.pi, NUM_OBJECTS)
    poses = np.zeros((NUM_OBJECTS, 3))
    placed: list[shapely.Polygon] = []
    for k, index in enumerate(order):
        angle = angles[k]
        if not placed:
            poses[index] = (0.0, 0.0, angle)
            placed.append(shapely.Polygon(object_polygon(index, 0.0, 0.0, angle, scale)))
            continue
        union = shapely.union_all(placed)
        centre = np.array([union.centroid.x, union.centroid.y])
        direction = rng.uniform(-math.pi, math.pi)
        u = np.array([math.cos(direction), math.sin(direction)])

        slide = _Slide(index, angle, centre, u, union, scale)
        # start just outside: the union's farthest point plus this object's radius
        xy = np.asarray(
            union.exterior.coords
            if union.geom_type == "Polygon"
            else union.convex_hull.exterior.coords
        )
        t = float(np.hypot(*(xy - centre).T).max()) + OBJECT_RADII[index] * scale + 0.005
        t = slide.march(t, 0.005)  # march in until the first contact
        # lo overlaps (or is at the centre), hi is free: bisect to 0.3 µm (14 halvings)
        hi = slide.bisect(t, t + 0.005, 14)
        # back off to leave a tiny gap (no initial interpenetration for the solver to undo)
        hi = slide.back_off(hi, TOUCH_GAP / 4, TOUCH_GAP)
        p = centre + hi * u
        poses[index] = (p[0], p[1], angle)
        placed.append(shapely.Polygon(object_polygon(index, p[0], p[1], angle, scale)))
    return poses


class _Slide:
    """Object `index` (at `angle`, its size × `scale`) slid along the line `centre + t u`
    towards `union`: its gap to the union at several `t` in one vectorised shapely call (the
    same vertices, bit for bit, as `object_polygon` at each point)."""

    def __init__(self, index, angle, centre, u, union, scale: float = 1.0) -> None:
        c, s = math.cos(angle), math.sin(angle)
        v = object_shapes(scale)[index]
        self.cv0, self.sv1, self.sv0, self.cv1 = c * v[:, 0], s * v[:, 1], s * v[:, 0], c * v[:, 1]
        self.centre, self.u, self.union = centre, u, union

    def gaps(self, ts) -> np.ndarray:
        ts = np.asarray(ts, dtype=np.float64)
        x = self.centre[0] + ts * self.u[0]
        y = self.centre[1] + ts * self.u[1]
        coords = np.empty((len(ts), len(self.cv0), 2))
        # evaluated as object_polygon does: (x + c v0) - s v1, (y + s v0) + c v1
        coords[:, :, 0] = x[:, None] + self.cv0 - self.sv1
        coords[:, :, 1] = y[:, None] + self.sv0 + self.cv1
        return shapely.distance(shapely.polygons(coords), self.union)

    def bisect(self, lo: float, hi: float, halvings: int, per_call: int = 4) -> float:
        """`hi` after `halvings` of `mid = (lo + hi) / 2; hi = mid if gap(mid) > 0 else
        lo = mid`, evaluating `per_call` levels of the decision tree per shapely call (the
        same mids, so the same answer, in a third of the calls)."""
        while halvings > 0:
            k = min(per_call, halvings)
            size = 2**k - 1
            # the tree's nodes (lo, hi) breadth first: node i's children are 2i + 1 (the gap
            # at its mid is positive: hi = mid) and 2i + 2 (lo = mid)
            nodes, mids = [(lo, hi)], []
            for i in range(size):
                a, b = nodes[i]
                mid = 0.5 * (a + b)
                mids.append(mid)
                if 2 * i + 1 < size:
                    nodes += [(a, mid), (mid, b)]
            gaps = self.gaps(mids)
            i = 0
            for _ in range(k):
                if gaps[i] > 0.0:
                    lo, hi, i = nodes[i][0], mids[i], 2 * i + 1
                else:
                    lo, hi, i = mids[i], nodes[i][1], 2 * i + 2
            halvings -= k
        return hi

    def back_off(self, t: float, step: float, gap: float) -> float:
        """`t` increased by `step` until the gap is at least `gap` (as `while gap(t) <
        gap: t += step`), several `t` per call."""
        while True:
            ts = [t]
            while len(ts) < 8:
                ts.append(ts[-1] + step)
            clear = np.flatnonzero(~(self.gaps(ts) < gap))
            if len(clear):
                return ts[clear[0]]
            t = ts[-1] + step

    def march(self, t: float, step: float) -> float:
        """`t` decreased by `step` until the object touches the union or `t` is not
        positive (as `while t > 0 and gap(t) > 0: t -= step`), several `t` per call."""
        size = 8  # usually enough (contact after ~6 steps); then 16 at a time
        while True:
            ts = [t]
            while len(ts) < size and ts[-1] > 0:
                ts.append(ts[-1] - step)
            if ts[-1] <= 0:
                ts.pop()  # never evaluated: the loop stops on it
            if ts:
                touching = np.flatnonzero(~(self.gaps(ts) > 0.0))
                if len(touching):
                    return ts[touching[0]]
                t = ts[-1] - step
                size = 16
            if t <= 0:
                return t


class SingulationWorld:
    """The pymunk space: four dynamic polygons and the kinematic fingertip.

    Build one from a joint pose and object poses; two builds from the same numbers step
    bit-identically. The joint pose is kept as numbers (the commanded pose, reached at the end
    of every step); the fingertip body follows it.

    Pickling (and so `copy.deepcopy`) stores the numbers the world was built from and the
    joint commands stepped since, and rebuilds it by replaying them: the copy continues
    bit-identically. (pymunk's own `Space.copy` does not: the contact cache the solver warm
    starts from is not restored, and a copy drifts by ~1e-5 m within 30 steps.)
    """

    def __init__(
        self,
        config: SceneConfig,
        theta: float,
        r: float,
        poses: np.ndarray,
        substeps: int = SUBSTEPS,
    ) -> None:
        self.config = config
        self.substeps = substeps
        self._initial = (float(theta), float(r), np.array(poses, dtype=np.float64))
        self._commands: list[tuple[float, float]] = []  # step() arguments since the build
        # the shapes hold their bodies by weak reference: self.bodies and self.tip keep them
        self.bodies: list[pymunk.Body] = []
        self._shapes: list[pymunk.Shape] = []
        for index in range(len(poses)):
            body = pymunk.Body()
            shape = pymunk.Poly(body, [tuple(v) for v in config.shapes[index]])
            # the body gets its mass when the shape is added
            shape.density = AREAL_DENSITY * config.mass_ratio ** (index / 3 - 0.5)
            shape.friction = FRICTION_OBJECTS * config.friction_scale
            self.bodies.append(body)
            self._shapes.append(shape)
        self.tip = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self._tip_shape = pymunk.Circle(self.tip, TIP_RADIUS)
        self._tip_shape.friction = FRICTION_TIP * config.friction_scale
        self._place(theta, r, poses)

    def restart(self, theta: float, r: float, poses: np.ndarray) -> None:
        """Put the world in the state a fresh build from these numbers starts in, bit for bit,
        at about half the cost: the shapes are kept, with new bodies (a used body keeps the
        solver's bias velocity) in a new space (no contact cache, the same shape ids). The
        supervisor's foresight restarts one world for every candidate push."""
        self._initial = (float(theta), float(r), np.array(poses, dtype=np.float64))
        self._commands = []
        self.space.remove(*self._shapes, self._tip_shape)  # the old bodies go with the space
        self.bodies = [pymunk.Body() for _ in self._shapes]
        for body, shape in zip(self.bodies, self._shapes, strict=True):
            shape.body = body
        self.tip = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self._tip_shape.body = self.tip
        self._place(theta, r, poses)

    def _place(self, theta: float, r: float, poses: np.ndarray) -> None:
        """Put the (new) bodies at the given poses and add everything to a new space."""
        self.theta = float(theta)
        self.r = float(r)
        space = pymunk.Space()
        space.gravity = (0.0, 0.0)
        space.damping = 0.0  # quasi-static: free velocity is gone after every substep
        space.collision_slop = 5e-4  # pymunk's default (0.1) assumes pixels, not metres
        poses = np.asarray(poses, dtype=np.float64)
        set_position, set_angle = _chipmunk.cpBodySetPosition, _chipmunk.cpBodySetAngle
        for body, shape, (x, y, angle) in zip(self.bodies, self._shapes, poses, strict=True):
            # body.position = ..., body.angle = ..., without the wrappers
            set_position(body._body, (float(x), float(y)))
            set_angle(body._body, float(angle))
            space.add(body, shape)
        set_position(self.tip._body, tip_position(self.theta, self.r))
        space.add(self.tip, self._tip_shape)
        self.space = space
        # read from the bodies once per step: poses (as floats, then as an array) and progress
        self._values: list[float] | None = None
        self._poses: np.ndarray | None = None
        self._progress = 0.0

    # -- pickling: rebuild and replay (exact) -----------------------------------------------

    def __getstate__(self) -> dict:
        theta, r, poses = self._initial
        return {
            "config": self.config,
            "substeps": self.substeps,
            "initial": (theta, r, poses.copy()),
            "commands": list(self._commands),
        }

    def __setstate__(self, state: dict) -> None:
        theta, r, poses = state["initial"]
        self.__init__(state["config"], theta, r, poses, state["substeps"])
        for command in state["commands"]:
            self.step(*command)

    # -- state ---------------------------------------------------------------------------

    def _read(self) -> None:
        """Read the bodies' poses (as floats, through the C bodies: no Vec2d per read) and the
        progress measure."""
        get_position, get_angle = _chipmunk.cpBodyGetPosition, _chipmunk.cpBodyGetAngle
        values = []
        for body in self.bodies:
            cbody = body._body
            p = get_position(cbody)
            values += (p.x, p.y, get_angle(cbody))
        self._values = values
        if len(self.bodies) == NUM_OBJECTS:
            self._progress = _progress4(values[0::3], values[1::3])
        else:
            self._progress = progress(np.array(values).reshape(-1, 3)[:, :2])

    def poses(self) -> np.ndarray:
        """Object poses (4, 3): x, y (m, centroid) and angle (rad, wrapped to [-pi, pi)).
        Read from the bodies once per step (a copy is returned)."""
        if self._poses is None:
            self._read()
            out = np.array(self._values).reshape(-1, 3)
            out[:, 2] = np.mod(out[:, 2] + math.pi, 2 * math.pi) - math.pi
            self._poses = out
        return self._poses.copy()

    def centres(self) -> np.ndarray:
        return self.poses()[:, :2]

    def tip_xy(self) -> tuple[float, float]:
        p = _chipmunk.cpBodyGetPosition(self.tip._body)
        return p.x, p.y

    def progress(self) -> float:
        """The continuous measure: max over objects of the distance to the nearest other (m).
        Read from the bodies once per step."""
        if self._values is None:
            self._read()
        return self._progress

    def is_singulated(self) -> bool:
        return self.progress() >= self.config.singulation_distance - SUCCESS_TOLERANCE

    # -- dynamics ------------------------------------------------------------------------

    def clip_pose(self, theta: float, r: float) -> tuple[float, float]:
        c = self.config
        return min(max(theta, c.theta_min), c.theta_max), min(max(r, c.r_min), c.r_max)

    def step(self, dtheta: float, dr: float) -> None:
        """Command a joint change (rad, m), clipped to the per-step limits and the joint limits;
        the fingertip moves along the joint-space segment and ends on the commanded pose."""
        self._commands.append((dtheta, dr))
        dtheta = min(max(dtheta, -MAX_DTHETA), MAX_DTHETA)
        dr = min(max(dr, -MAX_DR), MAX_DR)
        theta0, r0 = self.theta, self.r
        theta1, r1 = self.clip_pose(theta0 + dtheta, r0 + dr)
        n = self.substeps
        h = DT / n
        dtheta, dr = theta1 - theta0, r1 - r0
        # Space.step and the Body properties, without their Python wrappers (no callbacks,
        # no bodies added or removed here; every dynamic body has mass and moment > 0)
        ctip, cspace = self.tip._body, self.space._space
        get_position, set_velocity = _chipmunk.cpBodyGetPosition, _chipmunk.cpBodySetVelocity
        space_step = _chipmunk.cpSpaceStep
        cos, sin = math.cos, math.sin
        for k in range(1, n + 1):
            f = k / n
            th, rr = theta0 + f * dtheta, r0 + f * dr
            x, y = rr * cos(th), rr * sin(th)  # tip_position, inlined
            p = get_position(ctip)
            set_velocity(ctip, ((x - p.x) / h, (y - p.y) / h))
            space_step(cspace, h)
        set_velocity(ctip, (0.0, 0.0))
        # remove the last ulp of integration drift: the body sits exactly on the command
        _chipmunk.cpBodySetPosition(ctip, tip_position(theta1, r1))
        self.theta, self.r = theta1, r1
        self._values = self._poses = None
