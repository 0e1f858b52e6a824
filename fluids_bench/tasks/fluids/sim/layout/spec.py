"""The declarative description of an intersection: pure data, validated, JSON round-trippable.

A `LayoutSpec` says what is where (lanes, sidewalks, crosswalks, lights, extra drivable
areas, car routes and pedestrian walks). `fluids_bench.tasks.fluids.sim.layout.compiled` turns it into the
geometry and route arrays the simulator uses. Coordinates are metres, headings radians, durations
seconds. Errors name the element and field at fault.

Limits: `bounds` lie within ±`COORD_LIMIT` (1 km) of the origin and every point within
`bounds` grown by `POINT_SLACK` (1 km), so compiled paths (sampled every 0.5 m) stay
small. Geometrically impossible layouts are refused: a lane whose centreline crosses itself,
two lanes whose corridors (centreline ± width/2) overlap instead of meeting at their edges, a
route whose exit lane is some route's entry lane, a self-intersecting area or island, a kerb
radius that fills the space between the roads (`MAX_CURB_RADIUS`), and light timings no
clock can keep (`PHASE_RANGE`, an offset beyond one loop).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass

Point = tuple[float, float]

COORD_LIMIT = 1000.0  # m: |bounds| limit
POINT_SLACK = 1000.0  # m: how far outside ``bounds`` a point (kerbs, walks) may lie
LANE_OVERLAP = 0.05  # m²: lane corridors sharing more area than this overlap (touching is 0)
# Physical limits of a layout element: paths are sampled every 0.5 m, so a shorter lane, walk or
# crossing has no sample to drive or walk along; widths and speeds outside these bounds are no
# street (a 1e-300 m lane has no corridor, a 1e9 m one covers the world, 1e300 m/s overflows).
MIN_LENGTH = 0.5  # m
WIDTH_RANGE = (0.5, 50.0)  # m
MAX_SPEED_LIMIT = 50.0  # m/s (180 km/h)
# A light holds each state between 0.1 s (a simulation step) and an hour; its offset lies within
# one loop (it repeats every loop; 1e300 s leaves no precision for the time of day).
PHASE_RANGE = (0.1, 3600.0)  # s
# A kerb radius rounds the corners between roads: above 50 m, or a quarter of the layout's
# smaller side, it fills the space between the roads (500 m on a 93 m layout; 1e300 made GEOS
# fail).
MAX_CURB_RADIUS = 50.0  # m
TRAFFIC_STATES = ("green", "yellow", "red")
CROSSWALK_STATES = ("white", "red")


def _fail(where: str, field_name: str, value, allowed: str) -> None:
    raise ValueError(f"{where}: field '{field_name}' is {value!r}; allowed: {allowed}")


def _repeated(names) -> set[str]:
    """The names that occur more than once (in linear time: layouts may have 10,000 lanes)."""
    return {name for name, count in Counter(names).items() if count > 1}


def _check_points(where: str, name: str, pts, minimum: int) -> tuple[Point, ...]:
    try:
        out = tuple((float(x), float(y)) for x, y in pts)
    except (TypeError, ValueError):
        _fail(where, name, pts, "a list of [x, y] pairs of numbers")
    if len(out) < minimum:
        _fail(where, name, pts, f"at least {minimum} points")
    if not all(math.isfinite(c) for p in out for c in p):
        _fail(where, name, pts, "finite coordinates")
    return out


def _check_length(where: str, name: str, pts: tuple[Point, ...]) -> None:
    length = sum(math.dist(a, b) for a, b in zip(pts, pts[1:], strict=False))
    if length < MIN_LENGTH:
        _fail(where, name, pts, f"a path at least {MIN_LENGTH:g} m long (it is {length:.3g} m)")


def _check_in(where: str, name: str, value, lo: float, hi: float) -> float:
    """A finite number in `(lo, hi]` (`lo` excluded: widths and speeds are positive)."""
    v = _check_positive(where, name, value)
    if not lo < v <= hi:
        _fail(where, name, value, f"a number in ({lo:g}, {hi:g}]")
    return v


def _check_width(where: str, value) -> float:
    lo, hi = WIDTH_RANGE
    v = _check_positive(where, "width", value)
    if not lo <= v <= hi:
        _fail(where, "width", value, f"a number of metres in [{lo:g}, {hi:g}]")
    return v


def _check_positive(where: str, name: str, value) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or value <= 0
    ):
        _fail(where, name, value, "a finite number > 0")
    return float(value)


def _check_polygons(where: str, group: str, polygons) -> None:
    """Every polygon of `group` (`areas`, `islands`) must be valid: a self-intersecting
    one is refused when the layout is loaded, not when it is compiled."""
    if not polygons:
        return
    import shapely

    shapes = [shapely.Polygon(pts) for pts in polygons]
    for i, (pts, valid) in enumerate(zip(polygons, shapely.is_valid(shapes), strict=True)):
        if not valid:
            _fail(
                where,
                f"{group}[{i}]",
                pts,
                f"a simple polygon (this one: {shapely.is_valid_reason(shapes[i])})",
            )


@dataclass(frozen=True)
class Lane:
    """A directed lane: cars drive along `centerline` from its first to its last point."""

    name: str
    centerline: tuple[Point, ...]
    width: float = 3.5
    speed_limit: float = 10.0  # m/s
    light: str | None = None  # traffic light at the lane's end (its stop line)

    def __post_init__(self) -> None:
        where = f"lane '{self.name}'"
        object.__setattr__(
            self, "centerline", _check_points(where, "centerline", self.centerline, 2)
        )
        _check_length(where, "centerline", self.centerline)
        object.__setattr__(self, "width", _check_width(where, self.width))
        object.__setattr__(
            self,
            "speed_limit",
            _check_in(where, "speed_limit", self.speed_limit, 0, MAX_SPEED_LIMIT),
        )


@dataclass(frozen=True)
class Sidewalk:
    name: str
    centerline: tuple[Point, ...]
    width: float = 2.5

    def __post_init__(self) -> None:
        where = f"sidewalk '{self.name}'"
        object.__setattr__(
            self, "centerline", _check_points(where, "centerline", self.centerline, 2)
        )
        _check_length(where, "centerline", self.centerline)
        object.__setattr__(self, "width", _check_width(where, self.width))


@dataclass(frozen=True)
class Crosswalk:
    """A pedestrian crossing from `start` to `end` across a road, `width` wide."""

    name: str
    start: Point
    end: Point
    width: float = 3.0
    light: str | None = None

    def __post_init__(self) -> None:
        where = f"crosswalk '{self.name}'"
        a, b = _check_points(where, "start/end", (self.start, self.end), 2)
        _check_length(where, "start/end", (a, b))
        object.__setattr__(self, "start", a)
        object.__setattr__(self, "end", b)
        object.__setattr__(self, "width", _check_width(where, self.width))


@dataclass(frozen=True)
class Light:
    """A looping light. `phases` is a sequence of (state, seconds); `offset` shifts the loop.

    Traffic lights cycle through green/yellow/red, crosswalk lights through white/red, each state
    held for its duration, so any synchronisation scheme is a choice of durations and offsets.
    """

    name: str
    kind: str  # "traffic" or "crosswalk"
    position: Point
    phases: tuple[tuple[str, float], ...]
    offset: float = 0.0

    def __post_init__(self) -> None:
        where = f"light '{self.name}'"
        if self.kind not in ("traffic", "crosswalk"):
            _fail(where, "kind", self.kind, "'traffic' or 'crosswalk'")
        allowed = TRAFFIC_STATES if self.kind == "traffic" else CROSSWALK_STATES
        object.__setattr__(
            self, "position", _check_points(where, "position", [self.position], 1)[0]
        )
        phases = []
        lo, hi = PHASE_RANGE
        for state, seconds in self.phases:
            if state not in allowed:
                _fail(where, "phases", state, f"states {allowed}")
            seconds = _check_positive(where, "phases duration", seconds)
            if not lo <= seconds <= hi:
                _fail(where, "phases duration", seconds, f"a number of seconds in [{lo}, {hi:g}]")
            phases.append((str(state), seconds))
        if not phases:
            _fail(where, "phases", self.phases, "at least one (state, seconds) pair")
        object.__setattr__(self, "phases", tuple(phases))
        cycle = sum(seconds for _, seconds in phases)
        if (
            isinstance(self.offset, bool)
            or not isinstance(self.offset, int | float)
            or not math.isfinite(self.offset)
            or not -cycle <= self.offset <= cycle
        ):
            _fail(
                where,
                "offset",
                self.offset,
                f"a number of seconds in [-{cycle:g}, {cycle:g}] (one loop of the phases)",
            )
        object.__setattr__(self, "offset", float(self.offset))


@dataclass(frozen=True)
class CarRoute:
    """A legal movement: drive `entry` to its end, optionally through `via`, then `exit`."""

    entry: str
    exit: str
    via: tuple[Point, ...] = ()  # intermediate points (e.g. around a roundabout), else a Bézier

    def __post_init__(self) -> None:
        via = _check_points(f"route '{self.name}'", "via", self.via, 0)
        if len(via) == 1:
            _fail(f"route '{self.name}'", "via", self.via, "no points, or at least 2")
        object.__setattr__(self, "via", via)

    @property
    def name(self) -> str:
        return f"{self.entry}->{self.exit}"


@dataclass(frozen=True)
class Walk:
    """A pedestrian route: a polyline over sidewalks and crosswalks."""

    name: str
    waypoints: tuple[Point, ...]

    def __post_init__(self) -> None:
        where = f"walk '{self.name}'"
        object.__setattr__(self, "waypoints", _check_points(where, "waypoints", self.waypoints, 2))
        _check_length(where, "waypoints", self.waypoints)


@dataclass(frozen=True)
class LayoutSpec:
    """Everything static about a scene. `areas` are extra drivable polygons (junction cores);
    `curb_radius` rounds the concave corners of the road network; `islands` are non-drivable
    polygons cut out of it (a roundabout's centre); `sidewalk_width` > 0 borders every road with
    a sidewalk band (`sidewalks` adds explicit ones)."""

    name: str
    bounds: tuple[float, float, float, float]  # xmin, ymin, xmax, ymax
    lanes: tuple[Lane, ...]
    routes: tuple[CarRoute, ...]
    sidewalks: tuple[Sidewalk, ...] = ()
    crosswalks: tuple[Crosswalk, ...] = ()
    lights: tuple[Light, ...] = ()
    walks: tuple[Walk, ...] = ()
    areas: tuple[tuple[Point, ...], ...] = ()
    islands: tuple[tuple[Point, ...], ...] = ()
    curb_radius: float = 3.0
    sidewalk_width: float = 0.0  # > 0: a sidewalk band of this width borders all roads

    def __post_init__(self) -> None:
        where = f"layout '{self.name}'"
        b = self.bounds
        if len(b) != 4 or not all(math.isfinite(v) for v in b) or b[0] >= b[2] or b[1] >= b[3]:
            _fail(where, "bounds", b, "[xmin, ymin, xmax, ymax] with xmin < xmax and ymin < ymax")
        if any(abs(v) > COORD_LIMIT for v in b):
            _fail(
                where,
                "bounds",
                b,
                f"[xmin, ymin, xmax, ymax] within ±{COORD_LIMIT:g} m of the origin",
            )
        object.__setattr__(self, "bounds", tuple(float(v) for v in b))
        for group in ("lanes", "sidewalks", "crosswalks", "lights", "walks"):
            dup = _repeated(e.name for e in getattr(self, group))
            if dup:
                _fail(where, group, sorted(dup), "unique names")
        lanes = {lane.name for lane in self.lanes}
        lights = {light.name: light.kind for light in self.lights}
        traffic = sorted(n for n, k in lights.items() if k == "traffic")
        crossing = sorted(n for n, k in lights.items() if k == "crosswalk")
        for lane in self.lanes:
            if lane.light is not None and lights.get(lane.light) != "traffic":
                _fail(f"lane '{lane.name}'", "light", lane.light, f"a traffic light of {traffic}")
        for cw in self.crosswalks:
            if cw.light is not None and lights.get(cw.light) != "crosswalk":
                _fail(
                    f"crosswalk '{cw.name}'", "light", cw.light, f"a crosswalk light of {crossing}"
                )
        if not self.routes:
            _fail(where, "routes", self.routes, "at least one car route")
        dup = sorted(_repeated(r.name for r in self.routes))
        if dup:
            _fail(where, "routes", dup, "each movement (entry->exit) once")
        for r in self.routes:
            for end in ("entry", "exit"):
                if getattr(r, end) not in lanes:
                    _fail(f"route '{r.name}'", end, getattr(r, end), f"a lane of {sorted(lanes)}")
        entries = {r.entry for r in self.routes}
        for r in self.routes:
            if r.exit in entries:
                exits = sorted(lanes - entries)
                _fail(
                    f"route '{r.name}'",
                    "exit",
                    r.exit,
                    f"a lane no route starts from (cars cannot leave by an entry lane): {exits}",
                )
        object.__setattr__(
            self, "areas", tuple(_check_points(where, "areas", a, 3) for a in self.areas)
        )
        object.__setattr__(
            self, "islands", tuple(_check_points(where, "islands", a, 3) for a in self.islands)
        )
        for group in ("areas", "islands"):
            _check_polygons(where, group, getattr(self, group))
        curb = _check_positive(where, "curb_radius", self.curb_radius)
        limit = min(MAX_CURB_RADIUS, (b[2] - b[0]) / 4, (b[3] - b[1]) / 4)
        if curb > limit:
            _fail(
                where,
                "curb_radius",
                self.curb_radius,
                f"a number of metres in (0, {limit:g}] (at most {MAX_CURB_RADIUS:g} m and a "
                "quarter of the layout's smaller side: a larger radius fills the space between "
                "the roads)",
            )
        self._check_inside_bounds()
        self._check_lane_geometry()
        if not isinstance(self.sidewalk_width, int | float) or not 0 <= self.sidewalk_width < 50:
            _fail(where, "sidewalk_width", self.sidewalk_width, "a number in [0, 50) metres")

    def _check_inside_bounds(self) -> None:
        """Every point must lie within `bounds` (grown by 1 km of slack for kerbs and walks):
        a stray coordinate would otherwise make compiling allocate without limit."""
        xmin, ymin, xmax, ymax = self.bounds
        slack = POINT_SLACK
        groups = [(f"lane '{e.name}'", "centerline", e.centerline) for e in self.lanes]
        groups += [(f"sidewalk '{e.name}'", "centerline", e.centerline) for e in self.sidewalks]
        groups += [
            (f"crosswalk '{e.name}'", "start/end", (e.start, e.end)) for e in self.crosswalks
        ]
        groups += [(f"walk '{e.name}'", "waypoints", e.waypoints) for e in self.walks]
        groups += [(f"route '{r.name}'", "via", r.via) for r in self.routes]
        groups += [(f"light '{e.name}'", "position", (e.position,)) for e in self.lights]
        groups += [(f"layout '{self.name}'", f"areas[{i}]", a) for i, a in enumerate(self.areas)]
        groups += [
            (f"layout '{self.name}'", f"islands[{i}]", a) for i, a in enumerate(self.islands)
        ]
        for where, name, pts in groups:
            for x, y in pts:
                if not (xmin - slack <= x <= xmax + slack and ymin - slack <= y <= ymax + slack):
                    _fail(
                        where, name, (x, y), f"points within bounds {self.bounds} (± {slack:g} m)"
                    )

    def _check_lane_geometry(self) -> None:
        """Refuse lanes that cannot be driven: a self-crossing centreline, or two lanes whose
        corridors overlap (cars on them would collide head-on or sideways all along)."""
        import shapely

        lines = [shapely.LineString(lane.centerline) for lane in self.lanes]
        for lane, simple in zip(self.lanes, shapely.is_simple(lines), strict=True):
            if not simple:
                _fail(
                    f"lane '{lane.name}'",
                    "centerline",
                    lane.centerline,
                    "a polyline that does not cross or touch itself",
                )
        widths = [lane.width / 2 for lane in self.lanes]
        corridors = shapely.buffer(lines, widths, cap_style="flat")
        tree = shapely.STRtree(corridors)
        pairs = tree.query(corridors, predicate="intersects")
        for i, j in zip(*pairs, strict=True):
            if i < j:
                area = shapely.area(shapely.intersection(corridors[i], corridors[j]))
                if area > LANE_OVERLAP:
                    a, b = self.lanes[i], self.lanes[j]
                    _fail(
                        f"lane '{a.name}'",
                        "centerline",
                        a.centerline,
                        f"a lane meeting others only at its edges; it overlaps lane '{b.name}' "
                        f"over {area:.1f} m²",
                    )

    def lane(self, name: str) -> Lane:
        for lane in self.lanes:
            if lane.name == name:
                return lane
        raise KeyError(name)

    @property
    def entry_lanes(self) -> tuple[str, ...]:
        """Lanes some route starts from, in spec order."""
        seen: dict[str, None] = {}
        for r in self.routes:
            seen.setdefault(r.entry)
        return tuple(seen)

    def routes_from(self, entry: str) -> tuple[CarRoute, ...]:
        return tuple(r for r in self.routes if r.entry == entry)


__all__ = [
    "CROSSWALK_STATES",
    "TRAFFIC_STATES",
    "CarRoute",
    "Crosswalk",
    "LayoutSpec",
    "Lane",
    "Light",
    "Sidewalk",
    "Walk",
]
