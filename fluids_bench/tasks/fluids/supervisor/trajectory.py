"""Level 2 of the supervisor: the nominal trajectory, and getting back to it with OMPL.

Nominal paths are the layout's route paths: de Casteljau Bézier connectors between lane-end
waypoints, computed once per layout and cached (`fluids_bench.tasks.fluids.sim.layout.compiled`).
Pedestrians use the same mechanism along their walks.

With `trajectory_planner="ompl"`, OMPL plans every route's junction part instead
(`ompl_layout`): Dubins curves, valid where the footprint stays on the road.

When a car is off its route (the learner or injected noise pushed it there), OMPL plans a
kinematically feasible Dubins path back to a point of the route ahead, valid where the car's
footprint stays inside the drivable area. The direct Dubins connection to each candidate rejoin
point is tried first, in order: it is unique, so seeded episodes stay bit-identical. If none is
valid, two Dubins curves through the shortest valid via pose of a fixed lattice around the car
are tried (`DubinsPlanner.via`). No sampling planner is used: OMPL's RRT-Connect, tried
here before, found no exact path on one-lane roads, and on two-lane roads its paths depended on
OMPL's per-process random seed and on a wall-clock budget, so episodes were not reproducible.
"""

from __future__ import annotations

import functools

import numpy as np
import shapely

from fluids_bench.tasks.fluids.sim.config import CarConfig
from fluids_bench.tasks.fluids.sim.layout.compiled import (
    Layout,
    compile_layout,
    route_ends,
    with_route_middles,
)
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING, headings, resample
from fluids_bench.tasks.fluids.sim.layout.spec import LayoutSpec
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.kernels import mark_off_route

OFF_ROUTE_LATERAL = 1.5  # m from the path at which a car counts as off its route
OFF_ROUTE_HEADING = 0.8  # rad of heading error at which it does too
_NONE = np.zeros(0, dtype=np.int64)  # no agent off its route (read-only)
_NONE.setflags(write=False)
ROUTE_CLEARANCES = (0.4, 0.2, 0.0)  # m OMPL-planned routes try to keep from the kerb (PID slack)
REJOIN_AHEAD = (8.0, 12.0, 16.0, 20.0, 26.0, 32.0)  # m ahead on the route to try rejoining at
# the via-pose lattice of the two-curve fallback (DubinsPlanner.via), relative to the car's pose
VIA_RADII = (4.0, 7.0, 11.0)  # m from the car
VIA_BEARINGS = tuple(np.deg2rad(np.arange(-150, 181, 30)))  # rad from the car's heading
VIA_HEADINGS = tuple(np.deg2rad(np.arange(-135, 181, 45)))  # rad turned from the car's heading


def _ompl():
    from ompl import base as ob
    from ompl import util as ou

    ou.setLogLevel(ou.LogLevel.LOG_ERROR)
    return ob


def off_route(world: World) -> np.ndarray:
    """Indices of the active cars too far from their paths, by position or heading."""
    lateral, herr = world.tracking_error()
    mask = np.empty(world.n, dtype=np.bool_)
    count = mark_off_route(
        lateral, herr, world.active, world.is_car, OFF_ROUTE_LATERAL, OFF_ROUTE_HEADING, mask
    )
    return mask.nonzero()[0] if count else _NONE


class DubinsPlanner:
    """OMPL Dubins planning on one layout for one car size: forward-only paths of bounded
    curvature whose footprint stays in the drivable area."""

    def __init__(self, layout: Layout, car: CarConfig, clearance: float = 0.0) -> None:
        """`clearance` (m) is kept between the footprint and the road's edge (may be < 0)."""
        ob = _ompl()
        wheelbase = car.lf + car.lr
        # turning radius at 80% of full lock, so the PID has authority left to track it
        self.radius = wheelbase / np.tan(0.8 * car.max_steer)
        self.space = ob.DubinsStateSpace(float(self.radius))
        bounds = ob.RealVectorBounds(2)
        xmin, ymin, xmax, ymax = layout.bounds
        bounds.setLow(0, xmin)
        bounds.setLow(1, ymin)
        bounds.setHigh(0, xmax)
        bounds.setHigh(1, ymax)
        self.space.setBounds(bounds)
        self.area = layout.drivable.buffer(-clearance)
        shapely.prepare(self.area)
        hl, hw = car.length / 2, car.width / 2
        self._probe = np.array(
            [[hl, hw], [hl, -hw], [-hl, -hw], [-hl, hw], [hl, 0], [0, hw], [0, -hw], [-hl, 0]]
        )
        self.si = ob.SpaceInformation(self.space)
        self.si.setStateValidityChecker(self.valid)
        self.si.setStateValidityCheckingResolution(0.01)
        self.si.setup()

    def valid(self, state) -> bool:
        """The car's footprint (probed at corners and edge midpoints) lies in the drivable area."""
        x, y, yaw = state.getX(), state.getY(), state.getYaw()
        c, s = np.cos(yaw), np.sin(yaw)
        px = x + c * self._probe[:, 0] - s * self._probe[:, 1]
        py = y + s * self._probe[:, 0] + c * self._probe[:, 1]
        return bool(shapely.contains_xy(self.area, px, py).all())

    def state(self, x: float, y: float, yaw: float):
        st = self.space.allocState()
        st.setXY(float(x), float(y))
        st.setYaw(float(yaw))
        return st

    def direct(self, a, b) -> np.ndarray | None:
        """The shortest Dubins curve from `a` to `b` as points, if OMPL finds it valid."""
        if not self.si.checkMotion(a, b):
            return None
        length = self.space.distance(a, b)
        n = max(2, int(np.ceil(length / (PATH_SPACING / 2))) + 1)
        out = self.space.allocState()
        pts = []
        for t in np.linspace(0.0, 1.0, n):
            self.space.interpolate(a, b, float(t), out)
            pts.append((out.getX(), out.getY()))
        return np.asarray(pts)

    def via(self, a, b) -> np.ndarray | None:
        """Two Dubins curves `a` → v → `b` through the shortest valid via pose v of a fixed
        lattice around `a` (`VIA_RADII` × `VIA_BEARINGS` × `VIA_HEADINGS`),
        for when the direct curve leaves the road (a car turned round, or pushed onto the kerb).
        Candidates are tried in order of total Dubins length, ties by lattice order: no
        sampling and no time budget, so the result is the same on every run and machine load."""
        x, y, yaw = a.getX(), a.getY(), a.getYaw()
        vias = [
            self.state(x + r * np.cos(yaw + bear), y + r * np.sin(yaw + bear), yaw + turn)
            for r in VIA_RADII
            for bear in VIA_BEARINGS
            for turn in VIA_HEADINGS
        ]
        length = [self.space.distance(a, v) + self.space.distance(v, b) for v in vias]
        for i in np.argsort(length, kind="stable"):
            v = vias[i]
            if not self.valid(v):
                continue
            first = self.direct(a, v)
            if first is None:
                continue
            second = self.direct(v, b)
            if second is not None:
                return np.vstack([first, second[1:]])
        return None

    def through(self, guide: np.ndarray) -> np.ndarray | None:
        """A chain of valid Dubins curves through poses sampled along `guide` (a polyline),
        with as few pieces as possible: one direct curve if it is valid, else 2, 3, ... 24."""
        guide = resample(guide)
        head = headings(guide)
        for pieces in (1, 2, 3, 4, 6, 8, 12, 16, 24):
            idx = np.linspace(0, len(guide) - 1, pieces + 1).round().astype(int)
            poses = [self.state(*guide[i], head[i]) for i in idx]
            parts = [self.direct(p, q) for p, q in zip(poses[:-1], poses[1:], strict=True)]
            if all(p is not None for p in parts):
                return np.vstack([parts[0]] + [p[1:] for p in parts[1:]])
        return None


@functools.lru_cache(maxsize=16)
def ompl_layout(spec: LayoutSpec, car: CarConfig) -> Layout:
    """`spec`'s compiled layout with every car route's junction part planned by OMPL.

    Each route is joined from its entry lane's end to its exit lane's start by the fewest valid
    Dubins curves through poses of the default curve (deterministic: no sampling), keeping the
    most clearance from the kerb of `ROUTE_CLEARANCES` that allows it. A route OMPL cannot
    connect keeps its default curve.
    """
    layout = compile_layout(spec)
    planners = [DubinsPlanner(layout, car, clearance=c) for c in ROUTE_CLEARANCES]
    middles = {}
    routes = layout.routes
    for r, route in enumerate(spec.routes):
        p0, _, p1, _ = route_ends(spec, route)
        k0 = int(round(routes.enter_s[r] / PATH_SPACING))
        k1 = int(round(routes.clear_s[r] / PATH_SPACING))
        guide = np.vstack([p0, routes.path[r, k0 + 1 : k1], p1])
        for planner in planners:
            path = planner.through(guide)
            if path is not None:
                middles[r] = path
                break
    return with_route_middles(layout, middles)


class RecoveryPlanner(DubinsPlanner):
    """Plans Dubins paths from an agent's pose back onto its route."""

    def __init__(self, world: World) -> None:
        # a car pushed off the road must still find a way back: no clearance demanded
        super().__init__(world.layout, world.scene.car, clearance=-0.25)

    def plan(self, world: World, agent: int) -> bool:
        """Replace `agent`'s path by one from its pose back onto its route; True on success."""
        routes = world.layout.routes
        r = int(world.route[agent])
        x, y, th, _ = world.state[agent]
        start = self.state(x, y, th)
        base = max(world.route_s[agent], 0.0)
        limit = float(routes.length[r]) - 2.0
        candidates = [min(base + a, limit) for a in REJOIN_AHEAD]
        route_pts, route_head = routes.path[r], routes.heading[r]
        for s_goal in dict.fromkeys(candidates):
            k = int(round(s_goal / PATH_SPACING))
            bridge = self.direct(start, self.state(*route_pts[k], route_head[k]))
            if bridge is not None:
                return self._adopt(world, agent, bridge, k)
        # no direct connection: two curves through a via pose, to the nearest rejoin point
        # that one reaches (deterministic, like the direct curves)
        for s_goal in dict.fromkeys(candidates):
            k = int(round(s_goal / PATH_SPACING))
            bridge = self.via(start, self.state(*route_pts[k], route_head[k]))
            if bridge is not None:
                return self._adopt(world, agent, bridge, k)
        return False

    @staticmethod
    def _adopt(world: World, agent: int, bridge: np.ndarray, k_rejoin: int) -> bool:
        routes = world.layout.routes
        r = int(world.route[agent])
        n = int(round(routes.length[r] / PATH_SPACING)) + 1
        path = resample(np.vstack([bridge, routes.path[r, k_rejoin + 1 : n]]))
        world.set_path(agent, path, headings(path), (len(path) - 1) * PATH_SPACING)
        bridge_len = float(np.hypot(*np.diff(bridge, axis=0).T).sum())
        world.s[agent] = 0.0
        world.offset[agent] = k_rejoin * PATH_SPACING - bridge_len
        world.recovering[agent] = True
        world.lateral_error[agent] = world.heading_error[agent] = 0.0
        return True
