"""Turn a `LayoutSpec` into the static geometry and route arrays the simulator runs on.

Compiled once per spec and cached (specs are frozen and hashable): drivable area, sidewalks,
crosswalk polygons, terrain, and a route table in which every car route and pedestrian walk is a
path resampled every `PATH_SPACING` metres and padded into one array, so that all agents can be
projected along their paths with array indexing.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon, box

from fluids_bench.tasks.fluids.sim.layout.geometry import (
    PATH_SPACING,
    connector,
    curvature,
    headings,
    resample,
)
from fluids_bench.tasks.fluids.sim.layout.spec import LayoutSpec

CAR, PEDESTRIAN = 0, 1


@dataclass(frozen=True, eq=False)
class RouteTable:
    """All paths of a layout, cars first then walks, padded to a common length.

    `enter_s` is where the shared zone begins (a lane's end, the kerb before a crosswalk);
    `stop_s` is the same place when a light governs it (else `inf`); `clear_s` is where the
    agent has left the shared zone (an exit lane's start, the far kerb). Arc lengths are metres
    along the path; `inf` when absent.
    """

    names: tuple[str, ...]
    kind: np.ndarray  # (R,) CAR or PEDESTRIAN
    path: np.ndarray  # (R, M, 2) resampled at PATH_SPACING, padded with the last point
    heading: np.ndarray  # (R, M)
    curvature: np.ndarray  # (R, M) 1/m
    speed_limit: np.ndarray  # (R, M) m/s (inf for walks)
    length: np.ndarray  # (R,) m
    enter_s: np.ndarray  # (R,)
    stop_s: np.ndarray  # (R,)
    clear_s: np.ndarray  # (R,)
    light: np.ndarray  # (R,) index into Layout.lights, -1 if none
    entry: np.ndarray  # (R,) index into Layout.entry_lanes for cars, -1 for walks

    @property
    def car_routes(self) -> np.ndarray:
        return np.flatnonzero(self.kind == CAR)

    @property
    def walk_routes(self) -> np.ndarray:
        return np.flatnonzero(self.kind == PEDESTRIAN)


@dataclass(frozen=True, eq=False)
class Layout:
    """A compiled layout: the spec plus derived shapely geometry and the route table."""

    spec: LayoutSpec
    drivable: shapely.Geometry
    sidewalks: shapely.Geometry
    crosswalks: tuple[Polygon, ...]
    terrain: shapely.Geometry
    routes: RouteTable
    entry_lanes: tuple[str, ...]

    @functools.cached_property
    def drivable_tolerant(self) -> shapely.Geometry:
        """The drivable area grown by the off-road tolerance, prepared for fast predicates."""
        from fluids_bench.tasks.fluids.sim.collision import OFFROAD_TOLERANCE

        g = self.drivable.buffer(OFFROAD_TOLERANCE)
        shapely.prepare(g)
        return g

    @functools.cached_property
    def tolerant_boundary_vertices(self) -> np.ndarray:
        """Vertices of the grown drivable area's boundary, as complex numbers x + iy."""
        xy = shapely.get_coordinates(self.drivable_tolerant.boundary)
        return xy[:, 0] + 1j * xy[:, 1]

    def road_clearance(self, points: np.ndarray) -> np.ndarray:
        """Distance (m) from each of `points` (P, 2) to the edge of the grown drivable area:
        positive inside it, negative outside."""
        g = self.drivable_tolerant
        d = shapely.distance(g.boundary, shapely.points(points))
        return np.where(shapely.contains_xy(g, points[:, 0], points[:, 1]), d, -d)

    @functools.cached_property
    def route_clearance(self) -> np.ndarray:
        """`road_clearance` of every point of every route path (R, M)."""
        path = self.routes.path
        return self.road_clearance(path.reshape(-1, 2)).reshape(path.shape[:2])

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        return self.spec.bounds

    def routes_from_entry(self, entry: int) -> np.ndarray:
        """Car route indices starting at entry lane `entry`, in spec order (read-only)."""
        return self._routes_by_entry[entry]

    @functools.cached_property
    def _routes_by_entry(self) -> tuple[np.ndarray, ...]:
        by_entry = tuple(
            np.flatnonzero(self.routes.entry == e) for e in range(len(self.entry_lanes))
        )
        for routes in by_entry:
            routes.setflags(write=False)
        return by_entry


def _polygonal(g: shapely.Geometry) -> shapely.Geometry:
    """Drop the slivers of lower dimension that boolean operations can leave behind."""
    parts = [
        p
        for p in shapely.get_parts(g)
        if p.geom_type in ("Polygon", "MultiPolygon") and p.area > 1e-6
    ]
    return shapely.union_all(parts) if parts else Polygon()


def _lane_polygon(centerline, width: float) -> Polygon:
    return LineString(centerline).buffer(width / 2.0, cap_style="flat", join_style="mitre")


def route_ends(spec: LayoutSpec, route) -> tuple[np.ndarray, float, np.ndarray, float]:
    """Where a route leaves its entry lane and joins its exit lane: (point, heading) of each."""
    a = np.asarray(spec.lane(route.entry).centerline)
    b = np.asarray(spec.lane(route.exit).centerline)
    return (
        a[-1],
        float(np.arctan2(*(a[-1] - a[-2])[::-1])),
        b[0],
        float(np.arctan2(*(b[1] - b[0])[::-1])),
    )


def _car_path(
    spec: LayoutSpec, route, middle: np.ndarray | None = None
) -> tuple[np.ndarray, float, float]:
    """Resampled path of a route, the stop line's arc length and the exit lane's start.

    `middle` replaces the junction part (entry lane end to exit lane start) when given.
    """
    entry, exit_ = spec.lane(route.entry), spec.lane(route.exit)
    a = np.asarray(entry.centerline)
    b = np.asarray(exit_.centerline)
    h_in = float(np.arctan2(*(a[-1] - a[-2])[::-1]))
    h_out = float(np.arctan2(*(b[1] - b[0])[::-1]))
    if middle is not None:
        middle = np.asarray(middle, float)
    elif route.via:
        via = np.asarray(route.via)
        h_v0 = float(np.arctan2(*(via[1] - via[0])[::-1]))
        h_v1 = float(np.arctan2(*(via[-1] - via[-2])[::-1]))
        middle = np.vstack(
            [connector(a[-1], h_in, via[0], h_v0), via[1:-1], connector(via[-1], h_v1, b[0], h_out)]
        )
    else:
        middle = connector(a[-1], h_in, b[0], h_out)
    stop_s = float(LineString(a).length)
    clear_s = stop_s + float(LineString(middle).length)
    path = resample(np.vstack([a, middle[1:-1], b]))
    return path, stop_s, clear_s


def _walk_marks(
    path: np.ndarray, crosswalks, lights: dict[str, int], spec
) -> tuple[float, float, int]:
    """First and last arc length of a walk on a crosswalk, and that crosswalk's light."""
    s = np.arange(len(path)) * PATH_SPACING
    for poly, cw in zip(crosswalks, spec.crosswalks, strict=True):
        inside = shapely.contains_xy(poly, path[:, 0], path[:, 1])
        if inside.any():
            idx = np.flatnonzero(inside)
            light = lights[cw.light] if cw.light is not None else -1
            return float(s[idx[0]]) - 0.5, float(s[idx[-1]]), light
    return np.inf, np.inf, -1


def _pad(arrays: list[np.ndarray], width: int) -> np.ndarray:
    return np.stack(
        [np.concatenate([a, np.repeat(a[-1:], width - len(a), axis=0)]) for a in arrays]
    )


@functools.lru_cache(maxsize=32)
def compile_layout(spec: LayoutSpec) -> Layout:
    """Derive geometry and routes from `spec` (cached: every world on a spec shares one)."""
    bounds_box = box(*spec.bounds)
    for group in ("areas", "islands"):
        for i, pts in enumerate(getattr(spec, group)):
            poly = Polygon(pts)
            if not shapely.is_valid(poly):
                raise ValueError(
                    f"layout '{spec.name}': field '{group}[{i}]' is not a valid polygon "
                    f"({shapely.is_valid_reason(poly)}); allowed: a simple polygon"
                )
    roads = shapely.union_all(
        [_lane_polygon(lane.centerline, lane.width) for lane in spec.lanes]
        + [Polygon(a) for a in spec.areas]
    )
    rc = spec.curb_radius
    drivable = roads.buffer(rc, join_style="round").buffer(-rc, join_style="round")
    for island in spec.islands:
        drivable = drivable.difference(Polygon(island))
    drivable = _polygonal(drivable.intersection(bounds_box))
    side_parts = [_lane_polygon(s.centerline, s.width) for s in spec.sidewalks]
    if spec.sidewalk_width > 0:
        side_parts.append(
            drivable.buffer(spec.sidewalk_width, join_style="mitre").difference(drivable)
        )
    sidewalks = (
        _polygonal(shapely.union_all(side_parts).intersection(bounds_box))
        if side_parts
        else Polygon()
    )
    crosswalks = tuple(_lane_polygon((c.start, c.end), c.width) for c in spec.crosswalks)
    terrain = _polygonal(bounds_box.difference(shapely.union_all([drivable, sidewalks])))
    for g in (drivable, sidewalks, terrain):
        shapely.prepare(g)
    table = _route_table(spec, crosswalks, {})
    _check_islands(spec, table)
    return Layout(spec, drivable, sidewalks, crosswalks, terrain, table, spec.entry_lanes)


def _check_islands(spec: LayoutSpec, table: RouteTable) -> None:
    """An island is cut out of the road: no car route (its lanes and the junction curve
    between them) may run across one, or cars would be sent through a kerb (an island over
    the whole junction was accepted)."""
    for i, pts in enumerate(spec.islands):
        island = Polygon(pts)
        for r in table.car_routes:
            path = table.path[r]
            inside = shapely.contains_xy(island, path[:, 0], path[:, 1])
            if inside.any():
                x, y = path[np.flatnonzero(inside)[0]]
                raise ValueError(
                    f"layout '{spec.name}': field 'islands[{i}]' covers route "
                    f"'{table.names[r]}' at ({x:.1f}, {y:.1f}); allowed: islands no car route "
                    "runs across"
                )


def with_route_middles(layout: Layout, middles: dict[int, np.ndarray]) -> Layout:
    """A copy of `layout` whose car routes `middles` (route index → polyline from the entry
    lane's end to the exit lane's start) replace the default junction curves."""
    table = _route_table(layout.spec, layout.crosswalks, middles)
    return Layout(
        layout.spec,
        layout.drivable,
        layout.sidewalks,
        layout.crosswalks,
        layout.terrain,
        table,
        layout.entry_lanes,
    )


def _route_table(spec: LayoutSpec, crosswalks, middles: dict[int, np.ndarray]) -> RouteTable:
    light_index = {light.name: i for i, light in enumerate(spec.lights)}
    entry_lanes = spec.entry_lanes
    paths, names, kinds, enters, stops, clears, lights, entries, limits = ([] for _ in range(9))
    for r, route in enumerate(spec.routes):
        path, stop_s, clear_s = _car_path(spec, route, middles.get(r))
        entry, exit_ = spec.lane(route.entry), spec.lane(route.exit)
        s = np.arange(len(path)) * PATH_SPACING
        limits.append(np.where(s <= stop_s, entry.speed_limit, exit_.speed_limit))
        paths.append(path)
        names.append(route.name)
        kinds.append(CAR)
        enters.append(stop_s)
        stops.append(stop_s if entry.light is not None else np.inf)
        clears.append(clear_s)
        lights.append(light_index[entry.light] if entry.light is not None else -1)
        entries.append(entry_lanes.index(route.entry))
    for walk in spec.walks:
        path = resample(np.asarray(walk.waypoints))
        stop_s, clear_s, light = _walk_marks(path, crosswalks, light_index, spec)
        paths.append(path)
        names.append(walk.name)
        kinds.append(PEDESTRIAN)
        enters.append(stop_s)
        stops.append(stop_s if light >= 0 else np.inf)
        clears.append(clear_s)
        lights.append(light)
        entries.append(-1)
        limits.append(np.full(len(path), np.inf))
    width = max(len(p) for p in paths)
    table = RouteTable(
        names=tuple(names),
        kind=np.asarray(kinds, dtype=np.int8),
        path=_pad(paths, width),
        heading=_pad([headings(p) for p in paths], width),
        curvature=_pad([curvature(p) for p in paths], width),
        speed_limit=_pad(limits, width),
        length=np.asarray([(len(p) - 1) * PATH_SPACING for p in paths]),
        enter_s=np.asarray(enters, dtype=float),
        stop_s=np.asarray(stops, dtype=float),
        clear_s=np.asarray(clears, dtype=float),
        light=np.asarray(lights, dtype=np.int64),
        entry=np.asarray(entries, dtype=np.int64),
    )
    for arr in (
        table.kind,
        table.path,
        table.heading,
        table.curvature,
        table.speed_limit,
        table.length,
        table.enter_s,
        table.stop_s,
        table.clear_s,
        table.light,
        table.entry,
    ):
        arr.setflags(write=False)  # shared by every world on this layout
    return table
