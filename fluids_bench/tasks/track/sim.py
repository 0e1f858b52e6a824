"""The polygonal driving track of the source's ch. 6 and a car on it (no gymnasium).

Track: points drawn from a Gaussian centred in a square workspace, their convex hull kept when it
has five to seven edges (resampled otherwise), and a road of constant half-width `half_width`
around that polygon: a point is on the road iff its distance to the centre line is at most
`half_width`. Car: a point with a heading, moving `speed` units per step; each step the
steering action turns the heading instantly by -15°, 0 or +15°, then the car moves.

Leaving the road is a crash. The car is put back on the centre line a distance `reset_ahead`
beyond the point where it left, heading along the road there: resetting exactly at the
projection of where it left puts it back at the corner that caused the crash, where it crashes
again (a trap measured in the research note, hundreds of "crashes" per lap).

Units are workspace units (the bird's-eye image draws one unit as one pixel before
downsampling); headings are radians, counter-clockwise from +x. The track runs
counter-clockwise. Everything random is drawn from the caller's generator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from numba import njit

from fluids_bench.core.validation import check_float, check_int

TURN = math.radians(15.0)  # steering step of the source: {-15°, 0, +15°}
STEERING = (-TURN, 0.0, TURN)  # action index -> heading change
MAX_TRACK_TRIES = 10_000


@dataclass(frozen=True)
class TrackConfig:
    """Geometry of the generated tracks and the car (workspace units).

    The defaults make a lap about 90 steps long; a 15° turn every step drives a circle of
    diameter `speed / sin(7.5°)` ≈ 7.7 `speed`, wider than the road, so a car cannot turn
    round on the road: it goes forward or leaves the road.
    """

    workspace: float = 500.0
    spread: float = 100.0  # standard deviation of the Gaussian samples
    points: int = 10  # samples whose convex hull is the track
    min_edges: int = 5
    max_edges: int = 7
    half_width: float = 15.0
    speed: float = 10.0
    reset_ahead: float = 10.0  # arc length beyond the exit point where a crashed car is put back

    def __post_init__(self) -> None:
        where = "TrackConfig"
        check_float(where, "workspace", self.workspace, 0.0, lo_open=True)
        check_float(where, "spread", self.spread, 0.0, lo_open=True)
        check_int(where, "points", self.points, 3, 1000)
        check_int(where, "min_edges", self.min_edges, 3, 100)
        check_int(where, "max_edges", self.max_edges, self.min_edges, 100)
        if self.points < self.min_edges:
            raise ValueError(
                f"{where}: field 'points' is {self.points!r}; allowed: >= min_edges "
                f"({self.min_edges})"
            )
        check_float(where, "half_width", self.half_width, 0.0, self.workspace / 4, lo_open=True)
        check_float(where, "speed", self.speed, 0.0, self.workspace / 4, lo_open=True)
        check_float(where, "reset_ahead", self.reset_ahead, 0.0, self.workspace)


class Track:
    """A closed counter-clockwise polygon as the centre line, as arrays for the kernels."""

    def __init__(self, vertices: np.ndarray, half_width: float) -> None:
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        self.half_width = float(half_width)
        ends = np.roll(self.vertices, -1, axis=0)
        delta = ends - self.vertices
        self.lengths = np.hypot(delta[:, 0], delta[:, 1])
        self.directions = delta / self.lengths[:, None]
        self.headings = np.arctan2(delta[:, 1], delta[:, 0])
        self.starts = np.concatenate([[0.0], np.cumsum(self.lengths)[:-1]])  # arc of each vertex
        self.perimeter = float(self.lengths.sum())

    @property
    def edges(self) -> int:
        return len(self.vertices)

    def project(self, x: float, y: float) -> tuple[float, float, int]:
        """Distance to the centre line, arc length of the nearest point, and its segment."""
        return project(self.vertices, self.directions, self.lengths, self.starts, x, y)

    def point_at(self, arc: float) -> tuple[float, float, float]:
        """The centre-line point at arc length `arc` (any real; wrapped) and its heading."""
        arc = arc % self.perimeter
        seg = int(np.searchsorted(self.starts, arc, side="right") - 1)
        t = arc - self.starts[seg]
        x0, y0 = self.vertices[seg]
        dx, dy = self.directions[seg]
        return float(x0 + t * dx), float(y0 + t * dy), float(self.headings[seg])


def generate_track(rng: np.random.Generator, config: TrackConfig) -> Track:
    """Draw a track: the convex hull of Gaussian samples with `min_edges`–`max_edges` edges,
    whose road lies inside the workspace. Vertices counter-clockwise, starting at the hull
    vertex of smallest x (then y), so the track depends only on the samples."""
    centre = config.workspace / 2.0
    margin = config.half_width
    for _ in range(MAX_TRACK_TRIES):
        points = rng.normal(centre, config.spread, size=(config.points, 2))
        hull = shapely.convex_hull(shapely.multipoints(points))
        if not isinstance(hull, shapely.Polygon):
            continue
        ring = shapely.orient_polygons(hull).exterior  # counter-clockwise exterior
        vertices = np.asarray(ring.coords)[:-1]
        if not config.min_edges <= len(vertices) <= config.max_edges:
            continue
        if vertices.min() < margin or vertices.max() > config.workspace - margin:
            continue
        first = int(np.lexsort((vertices[:, 1], vertices[:, 0]))[0])
        return Track(np.roll(vertices, -first, axis=0), config.half_width)
    raise RuntimeError(f"no track with {config.min_edges}-{config.max_edges} edges found")


@njit(cache=True, nogil=True)
def project(vertices, directions, lengths, starts, x, y):  # pragma: no cover (compiled)
    """Distance from (x, y) to the closed polyline, the arc length of the nearest point and
    its segment (the first segment among equal distances)."""
    best_d2, best_arc, best_seg = np.inf, 0.0, 0
    for k in range(vertices.shape[0]):
        ox, oy = x - vertices[k, 0], y - vertices[k, 1]
        t = ox * directions[k, 0] + oy * directions[k, 1]
        t = min(max(t, 0.0), lengths[k])
        ex, ey = ox - t * directions[k, 0], oy - t * directions[k, 1]
        d2 = ex * ex + ey * ey
        if d2 < best_d2:
            best_d2, best_arc, best_seg = d2, starts[k] + t, k
    return math.sqrt(best_d2), best_arc, best_seg


def wrap_arc(delta: float, perimeter: float) -> float:
    """An arc-length difference wrapped into [-perimeter/2, perimeter/2)."""
    return (delta + perimeter / 2.0) % perimeter - perimeter / 2.0


@dataclass
class CarState:
    """Pose of the car, the distance it has progressed along the track since the start of the
    episode (arc length, unwrapped), and the episode's crash count."""

    x: float
    y: float
    heading: float
    arc: float  # arc length of the nearest centre-line point, in [0, perimeter)
    progress: float = 0.0
    crashes: int = 0
    steps: int = 0


class TrackSim:
    """One car on one track: `step(action)` moves it and applies the crash-and-replace rule."""

    def __init__(self, track: Track, config: TrackConfig) -> None:
        self.track = track
        self.config = config
        self.car = CarState(*track.point_at(0.0), arc=0.0)

    def place(self, arc: float, lateral: float = 0.0, heading_offset: float = 0.0) -> None:
        """Start an episode at arc length `arc`, `lateral` units left of the centre line,
        heading `heading_offset` from the road's direction there."""
        x, y, heading = self.track.point_at(arc)
        # left normal of a counter-clockwise track points inwards
        x -= lateral * math.sin(heading)
        y += lateral * math.cos(heading)
        _, arc_now, _ = self.track.project(x, y)
        self.car = CarState(x, y, heading + heading_offset, arc=arc_now)

    @property
    def laps(self) -> float:
        """Laps driven so far (fractional)."""
        return self.car.progress / self.track.perimeter

    def step(self, action: int) -> bool:
        """Steer by `STEERING[action]`, move one step; return whether the car crashed."""
        car, track = self.car, self.track
        heading = car.heading + STEERING[action]
        x = car.x + self.config.speed * math.cos(heading)
        y = car.y + self.config.speed * math.sin(heading)
        distance, arc, _ = track.project(x, y)
        crashed = distance > track.half_width
        if crashed:
            x, y, heading = track.point_at(arc + self.config.reset_ahead)
            arc = (arc + self.config.reset_ahead) % track.perimeter
            car.crashes += 1
        car.progress += wrap_arc(arc - car.arc, track.perimeter)
        car.x, car.y, car.heading, car.arc = x, y, wrap_heading(heading), arc
        car.steps += 1
        return crashed

    def lookahead(self, distances: np.ndarray) -> np.ndarray:
        """Centre-line points `distances` ahead of the car's nearest point, in the car's frame
        (x forward, y left), flattened: (2 * len(distances),)."""
        car = self.car
        out = np.empty((len(distances), 2))
        c, s = math.cos(car.heading), math.sin(car.heading)
        for i, d in enumerate(distances):
            px, py, _ = self.track.point_at(car.arc + d)
            dx, dy = px - car.x, py - car.y
            out[i] = (c * dx + s * dy, -s * dx + c * dy)
        return out.reshape(-1)


def wrap_heading(angle: float) -> float:
    """An angle wrapped into [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi
