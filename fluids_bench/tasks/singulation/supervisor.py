"""The singulation supervisor: behaviour, trajectory and control levels (as FLUIDS' stack).

* **Behaviour** (`SingulationSupervisor._replan`): which object to push and in which
  direction. Candidates are every object × `DIRECTIONS` world directions; each gets a
  pre-push point behind the object (the first point, backing off along the push line, where
  the fingertip clears every object). Candidates whose pre-push point is out of reach or has
  no collision-free approach are dropped; the rest are simulated (foresight) on a world
  rebuilt from the current state, the fingertip placed at the pre-push point and pushing along
  the line. The pick: the fewest total steps among those that singulate with a margin, else
  the largest progress reached.
* **Trajectory** (`route`): joint-space waypoints from the fingertip to the pre-push
  point, the shortest collision-free of direct / retract–rotate–extend /
  extend–rotate–retract; then the push line.
* **Control** (`joint_action`, `line_action`): the per-step joint change toward the
  current waypoint (or along the push line), scaled into the per-step limits.

Labels are cheap between replans: the chosen push is cached with the object poses it was
planned for, and re-planned only when the objects leave that plan (moved by more than a few
millimetres before the push, the target off the push line during it) or when the push ends.
The trajectory and control levels are cheap geometry recomputed from the current fingertip
pose, so a fingertip a learner drove elsewhere gets the route from where it is.
The supervisor reads the world's true state, never an observation.
"""

from __future__ import annotations

import functools
import heapq
import math
import time
from dataclasses import dataclass

import numpy as np

from fluids_bench.tasks.singulation.sim import (
    MAX_DR,
    MAX_DTHETA,
    NUM_OBJECTS,
    TIP_RADIUS,
    SingulationWorld,
    joint_pose,
    object_shapes,
    progress,
)

DIRECTIONS = 12  # push directions tried per object, evenly spaced
CLEARANCE = TIP_RADIUS + 0.004  # fingertip centre to object, transit
STANDOFF = TIP_RADIUS + 0.008  # fingertip centre to object at the pre-push point
ROUTE_MARGIN = 0.012  # extra radius kept from the objects on the retract / extend arcs
PUSH_MAX_STEPS = 14  # foresight horizon of one push
STALL_STEPS = 4  # foresight gives up on a push that has not helped for this many steps
FORESIGHT_SUBSTEPS = 5  # physics substeps per step in the foresight (the world uses 10)
SUCCESS_MARGIN = 0.012  # plan pushes to 10 cm + this, so noise does not undo them
REACHED = 0.003  # m: the fingertip is at the pre-push point
POSE_TOLERANCE = 0.003  # m: objects moved more than this before the push -> replan
ANGLE_TOLERANCE = 0.05  # rad
LINE_TOLERANCE = 0.015  # m: fingertip this far off the push line -> replan
TARGET_TOLERANCE = 0.03  # m: target centre this far off the push line -> replan
PUSH_EXTRA = 0.01  # m pushed beyond the foresight's best point
LOOKAHEAD = 0.012  # m along the push line per step (the joint limits cap it further)


# -- geometry ---------------------------------------------------------------------------------


# the objects' vertices padded to a common count (padding repeats the last vertex), and each
# vertex's successor around its polygon (np.roll(..., -1, axis=1) as an index: cheaper)
_K = max(len(s) for s in object_shapes())
_NEXT = np.roll(np.arange(_K), -1)


@functools.lru_cache(maxsize=32)
def _padded_shapes(scale: float) -> np.ndarray:
    """The objects' vertices (size × `scale`) padded to `_K` each (read-only)."""
    out = np.array([[*s, *[s[-1]] * (_K - len(s))] for s in object_shapes(scale)])
    out.setflags(write=False)
    return out


def polygons(poses: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """World vertices padded to a common count (n, k, 2) (padding repeats the last vertex):
    `object_polygon` of every object (their size ×
    `scale`), in one go."""
    if len(poses) != NUM_OBJECTS:
        raise ValueError(f"polygons: poses has {len(poses)} rows; allowed: {NUM_OBJECTS}")
    # math.cos / math.sin as object_polygon (numpy's may differ in the last bit)
    c = np.array([math.cos(a) for a in poses[:, 2].tolist()])[:, None]
    s = np.array([math.sin(a) for a in poses[:, 2].tolist()])[:, None]
    shapes = _padded_shapes(scale)
    vx, vy = shapes[:, :, 0], shapes[:, :, 1]
    out = np.empty((len(poses), _K, 2))
    out[:, :, 0] = poses[:, 0:1] + c * vx - s * vy
    out[:, :, 1] = poses[:, 1:2] + s * vx + c * vy
    return out


def edge_planes(verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outward unit normals (n, k, 2) and offsets (n, k) of counter-clockwise convex polygons;
    padded (zero-length) edges get a plane that never binds."""
    e = verts[:, _NEXT] - verts
    length = np.hypot(e[..., 0], e[..., 1])
    safe = np.where(length > 0, length, 1.0)
    normals = np.stack((e[..., 1], -e[..., 0]), axis=-1) / safe[..., None]
    offsets = np.einsum("nkd,nkd->nk", normals, verts)
    offsets = np.where(length > 0, offsets, np.inf)
    return normals, offsets


def blocked(
    points: np.ndarray, planes: tuple[np.ndarray, np.ndarray], clearance: float
) -> np.ndarray:
    """Per point (m, 2): within `clearance` of any polygon (the polygon grown by moving every
    edge outwards, a slight over-estimate at corners: conservative)."""
    normals, offsets = planes
    n, k = offsets.shape
    s = (normals.reshape(n * k, 2) @ points.T).reshape(n, k, len(points))
    s -= offsets[:, :, None]
    return (s.max(axis=1) < clearance).any(axis=0)


def radial_extent(verts: np.ndarray) -> tuple[float, float]:
    """Smallest and largest distance from the arm base to any object (lower bound, exact max)."""
    radii = np.hypot(verts[..., 0], verts[..., 1])
    # a polygon's closest point may lie on an edge: at most half an edge closer than a vertex
    edges = np.hypot(*(verts[:, _NEXT] - verts).transpose(2, 0, 1))
    return float((radii - edges / 2).min()), float(radii.max())


@functools.lru_cache(maxsize=512)
def _fractions(n: int) -> np.ndarray:
    """`np.linspace(0, 1, n)`, made once per `n` (read-only)."""
    f = np.linspace(0.0, 1.0, n)
    f.setflags(write=False)
    return f


def segment_points(a: tuple[float, float], b: tuple[float, float]) -> np.ndarray:
    """Fingertip positions along the joint-space segment a -> b (theta, r), about 5 mm apart."""
    (t0, r0), (t1, r1) = a, b
    length = abs(t1 - t0) * max(r0, r1) + abs(r1 - r0)
    f = _fractions(max(2, int(length / 0.005) + 2))
    th = t0 + f * (t1 - t0)
    rr = r0 + f * (r1 - r0)
    return np.column_stack((rr * np.cos(th), rr * np.sin(th)))


def joint_steps(a: tuple[float, float], b: tuple[float, float]) -> float:
    return max(abs(b[0] - a[0]) / MAX_DTHETA, abs(b[1] - a[1]) / MAX_DR)


def route(
    world_limits: tuple[float, float, float, float],
    start: tuple[float, float],
    goal: tuple[float, float],
    verts: np.ndarray,
    planes: tuple[np.ndarray, np.ndarray],
    cache: dict | None = None,
) -> tuple[list[tuple[float, float]], float] | None:
    """The shortest collision-free joint-space route start -> goal (waypoints after `start`
    and its length in steps), trying direct, retract–rotate–extend and extend–rotate–retract;
    None when none is clear. Near the start a fingertip already touching an object may move
    away from it. `cache` (a dict, empty at first) keeps what depends only on `start` and
    the objects between calls with the same ones."""
    cache = {} if cache is None else cache
    r_lo, r_hi = world_limits[2], world_limits[3]
    if "extent" not in cache:
        cache["extent"] = radial_extent(verts)
    inner, outer = cache["extent"]
    r_in = max(r_lo, min(start[1], goal[1], inner - CLEARANCE - ROUTE_MARGIN))
    r_out = min(r_hi, max(start[1], goal[1], outer + CLEARANCE + ROUTE_MARGIN))
    options = [
        [goal],
        [(start[0], r_in), (goal[0], r_in), goal],
        [(start[0], r_out), (goal[0], r_out), goal],
    ]
    sx, sy = start[1] * math.cos(start[0]), start[1] * math.sin(start[0])
    start_blocked = cache.get("start_blocked")
    costed = []
    for waypoints in options:
        here, steps = start, 0.0
        for w in waypoints:
            steps += joint_steps(here, w)
            here = w
        costed.append((steps, waypoints))
    costed.sort(key=lambda item: item[0])
    for steps, waypoints in costed:  # shortest first: the first clear one wins
        pts, here = [], start
        for w in waypoints:
            if abs(w[0] - here[0]) + abs(w[1] - here[1]) > 1e-12:
                pts.append(segment_points(here, w))
            here = w
        if pts:
            p = np.concatenate(pts)
            if start_blocked is None:
                start_blocked = bool(blocked(np.array([[sx, sy]]), planes, CLEARANCE)[0])
                cache["start_blocked"] = start_blocked
            if start_blocked:  # let a fingertip in contact leave: skip its first 2 cm
                p = p[np.hypot(p[:, 0] - sx, p[:, 1] - sy) > 0.02]
            if len(p) and blocked(p, planes, CLEARANCE).any():
                continue
        return [w for w in waypoints if abs(w[0] - start[0]) + abs(w[1] - start[1]) > 1e-12] or [
            goal
        ], steps
    return None


# -- control ----------------------------------------------------------------------------------


def joint_action(start: tuple[float, float], goal: tuple[float, float]) -> tuple[float, float]:
    """(dtheta, dr) toward `goal` along the joint-space line, scaled into the limits."""
    dth, dr = goal[0] - start[0], goal[1] - start[1]
    scale = max(1.0, abs(dth) / MAX_DTHETA, abs(dr) / MAX_DR)
    return dth / scale, dr / scale


def line_action(
    tip: tuple[float, float], origin: np.ndarray, direction: np.ndarray, end: float
) -> tuple[float, float]:
    """(dtheta, dr) that moves the fingertip along the push line (back onto it if it drifted)
    by up to `LOOKAHEAD`, not beyond the line's `end` (distance from `origin`)."""
    rel = np.array(tip) - origin
    s = float(rel @ direction)
    target = origin + min(s + LOOKAHEAD, end) * direction
    goal = joint_pose(float(target[0]), float(target[1]))
    here = joint_pose(*tip)
    return joint_action(here, goal)


def normalised(dtheta: float, dr: float) -> np.ndarray:
    return np.array(
        [min(max(dtheta / MAX_DTHETA, -1.0), 1.0), min(max(dr / MAX_DR, -1.0), 1.0)],
        dtype=np.float32,
    )


# -- behaviour --------------------------------------------------------------------------------


@dataclass
class PushPlan:
    """One push: the object, the line (origin = pre-push point, unit direction), how far to
    push (metres along the line from the origin), the object poses it was planned for and the
    foresight's verdict."""

    target: int
    origin: np.ndarray
    direction: np.ndarray
    end: float
    poses: np.ndarray
    predicted_progress: float
    predicted_steps: float
    pushing: bool = False
    # the approach route's remaining waypoints, valid while the fingertip is at route_from
    route: list[tuple[float, float]] | None = None
    route_from: tuple[float, float] | None = None


class SingulationSupervisor:
    """The hierarchical supervisor; `action` is the label for the world's current state."""

    def __init__(self) -> None:
        self.plan: PushPlan | None = None
        self._no_plan_for: np.ndarray | None = None  # poses for which no push was found
        # the objects' vertices and edge planes, with the poses (as bytes) they are for
        self._geometry: tuple[bytes, np.ndarray, tuple] | None = None
        self.replans = 0
        # time spent planning (statistics only, never read); wall-clock, because reading a
        # CPU-time clock costs 0.1-2 ms after a burst of work on some sandboxed kernels
        self.replan_seconds = 0.0

    # the label --------------------------------------------------------------------------

    def action(self, world: SingulationWorld) -> np.ndarray:
        """The normalised action `[dtheta / 1.5°, dr / 1 cm]` the supervisor takes now."""
        poses = world.poses()
        tip = world.tip_xy()
        here = (world.theta, world.r)
        if world.progress() >= world.config.singulation_distance + SUCCESS_MARGIN / 2:
            return normalised(0.0, 0.0)  # done: hold still
        if not self._plan_holds(poses, tip):
            self._replan(world, poses)
        plan = self.plan
        if plan is None:  # nothing reachable: wait at home
            c = world.config
            return normalised(*joint_action(here, (c.home_theta, c.home_r)))
        if not plan.pushing and math.dist(tip, plan.origin) <= REACHED:
            plan.pushing = True
        if plan.pushing:
            return normalised(*line_action(tip, plan.origin, plan.direction, plan.end))
        c = world.config
        if plan.route is not None and plan.route_from == here:
            waypoints = plan.route  # the fingertip went where the last label sent it
        else:
            key = poses.tobytes()
            if self._geometry is None or self._geometry[0] != key:  # the objects moved
                verts = polygons(poses, c.object_size_scale)
                self._geometry = (key, verts, edge_planes(verts))
            _, verts, planes = self._geometry
            limits = (c.theta_min, c.theta_max, c.r_min, c.r_max)
            found = route(limits, here, joint_pose(*plan.origin), verts, planes)
            if found is None:  # boxed in (a learner's state): back straight out to the base
                plan.route = None
                return normalised(*joint_action(here, (here[0], c.r_min)))
            waypoints = found[0]
        label = normalised(*joint_action(here, waypoints[0]))
        # where the env will put the fingertip (float32 action and clipping included)
        after = world.clip_pose(
            here[0] + float(label[0]) * MAX_DTHETA, here[1] + float(label[1]) * MAX_DR
        )
        reached = abs(after[0] - waypoints[0][0]) + abs(after[1] - waypoints[0][1]) < 1e-6
        plan.route = waypoints[1:] if reached and len(waypoints) > 1 else waypoints
        plan.route_from = after
        return label

    # plan bookkeeping --------------------------------------------------------------------

    def _plan_holds(self, poses: np.ndarray, tip: tuple[float, float]) -> bool:
        plan = self.plan
        if plan is None:
            return self._no_plan_for is not None and bool(np.array_equal(self._no_plan_for, poses))
        if not plan.pushing:
            moved = np.hypot(*(poses[:, :2] - plan.poses[:, :2]).T).max()
            turned = np.abs(np.angle(np.exp(1j * (poses[:, 2] - plan.poses[:, 2])))).max()
            return moved <= POSE_TOLERANCE and turned <= ANGLE_TOLERANCE
        d, o = plan.direction, plan.origin
        rel = np.array(tip) - o
        along = float(rel @ d)
        off_line = abs(float(rel[0] * d[1] - rel[1] * d[0]))
        t = poses[plan.target, :2] - o
        target_off = abs(float(t[0] * d[1] - t[1] * d[0]))
        return (
            along < plan.end - 1e-4
            and off_line <= LINE_TOLERANCE
            and target_off <= TARGET_TOLERANCE
        )

    def _replan(self, world: SingulationWorld, poses: np.ndarray) -> None:
        self.replans += 1
        start = time.perf_counter()
        self.plan = plan_push(world, poses)
        self.replan_seconds += time.perf_counter() - start
        self._no_plan_for = poses.copy() if self.plan is None else None


def candidate_pushes(world: SingulationWorld, poses: np.ndarray):
    """(target, pre-push point, direction) of every candidate whose push stays within reach,
    with the objects' vertices and edge planes. The pre-push point backs off from the target's
    centre against the push direction to the first point where the fingertip stands clear of
    every object by `STANDOFF` (all candidates in one vectorised test)."""
    c = world.config
    verts = polygons(poses, c.object_size_scale)
    planes = edge_planes(verts)
    angles = 2 * math.pi * np.arange(DIRECTIONS) / DIRECTIONS
    dirs = np.column_stack((np.cos(angles), np.sin(angles)))
    back = np.arange(0.0, 0.25, 0.003)
    # points (object, direction, distance back, xy)
    pts = poses[:, None, None, :2] - back[None, None, :, None] * dirs[None, :, None, :]
    free = ~blocked(pts.reshape(-1, 2), planes, STANDOFF).reshape(pts.shape[:3])
    first = np.argmax(free, axis=2)
    margin = math.radians(2.0)
    out = []
    for i in range(NUM_OBJECTS):
        for j, d in enumerate(dirs):
            if not free[i, j, first[i, j]]:
                continue
            origin = pts[i, j, first[i, j]]
            goal = joint_pose(*origin)
            end_point = joint_pose(*(origin + 0.14 * d))
            inside = (
                c.theta_min + margin <= goal[0] <= c.theta_max - margin
                and c.r_min + 0.01 <= goal[1] <= c.r_max - 0.01
                and c.theta_min <= end_point[0] <= c.theta_max
                and c.r_min <= end_point[1] <= c.r_max
            )
            if inside:
                out.append((i, origin, d))
    return out, verts, planes


def simulate_push(
    world: SingulationWorld,
    poses: np.ndarray,
    origin: np.ndarray,
    direction: np.ndarray,
    horizon: int = PUSH_MAX_STEPS,
    scratch: SingulationWorld | None = None,
) -> tuple[float, int, float]:
    """Foresight: push from `origin` along `direction` on a rebuilt world (`scratch`, a
    foresight world restarted from the state, when given). Returns the best progress reached,
    the step it was reached at and how far along the line the fingertip was."""
    theta, r = joint_pose(*origin)
    if scratch is None:
        sim = SingulationWorld(world.config, theta, r, poses, FORESIGHT_SUBSTEPS)
    else:
        sim = scratch
        sim.restart(theta, r, poses)
    best, best_step, best_s = progress(poses[:, :2]), 0, 0.0
    goal = world.config.singulation_distance + SUCCESS_MARGIN
    for k in range(1, horizon + 1):
        sim.step(*line_action(sim.tip_xy(), origin, direction, 0.3))
        p = sim.progress()
        if p > best + 1e-4:
            best, best_step = p, k
            best_s = float((np.array(sim.tip_xy()) - origin) @ direction)
        if p >= goal or k - best_step >= STALL_STEPS:
            break  # done, or the push stopped helping
    return best, best_step, best_s


def plan_push(world: SingulationWorld, poses: np.ndarray) -> PushPlan | None:
    """The behaviour level: simulate reachable candidate pushes and pick one.

    Candidates are taken in order of approach length (lazily: the direct joint-space distance
    is a lower bound, the collision-free route is computed only when a candidate comes up);
    once a push is known to singulate in `C` steps, candidates whose approach alone takes
    `C` steps or more cannot beat it and are neither routed nor simulated (branch and bound:
    the same pick as trying all, for far fewer simulations)."""
    c = world.config
    goal = c.singulation_distance + SUCCESS_MARGIN
    limits = (c.theta_min, c.theta_max, c.r_min, c.r_max)
    here = (world.theta, world.r)
    candidates, verts, planes = candidate_pushes(world, poses)
    heap = [
        (joint_steps(here, joint_pose(*origin)), k, False)
        for k, (_, origin, _) in enumerate(candidates)
    ]
    heapq.heapify(heap)
    best: PushPlan | None = None
    best_key = None
    scratch = None  # one foresight world, restarted for every candidate
    route_cache: dict = {}  # every route starts here, among the same objects
    while heap:
        approach, k, exact = heapq.heappop(heap)
        if best_key is not None and best_key[0] == 0 and approach + 1 >= best_key[1]:
            break
        target, origin, d = candidates[k]
        if not exact:
            found = route(limits, here, joint_pose(*origin), verts, planes, route_cache)
            if found is not None:
                heapq.heappush(heap, (found[1], k, True))
            continue
        horizon = PUSH_MAX_STEPS
        if best_key is not None and best_key[0] == 0:  # must beat the best success to matter
            horizon = min(horizon, int(math.ceil(best_key[1] - approach)) - 1)
        if scratch is None:
            scratch = SingulationWorld(world.config, *here, poses, FORESIGHT_SUBSTEPS)
        reached, step, s = simulate_push(world, poses, origin, d, horizon, scratch)
        if step == 0:
            continue
        success = reached >= goal
        # successes: fewest steps; otherwise: most progress
        key = (0, approach + step) if success else (1, -reached)
        if best_key is None or key < best_key:
            best_key = key
            # push a little past the predicted point: the real push runs from a fingertip
            # that arrived by its approach route, not exactly the foresight's start
            best = PushPlan(
                target, origin, d, s + PUSH_EXTRA, poses.copy(), reached, approach + step
            )
    return best
