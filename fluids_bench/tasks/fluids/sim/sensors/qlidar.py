"""The quasi-LIDAR observation of ch. 7: `m` rays around the ego, each reporting what it hits.

Ray `k` (k = 0 … m−1) leaves the ego's centre at angle `θ_ego + 2πk/m` (counter-clockwise,
ray 0 straight ahead; equal spacing over 360° with no duplicated ray at ±180°). Each ray reads a
row `[d, label, ψ_r, v_r]` of the float32 observation of shape (m, 4):

* `d`: distance (m) to the nearest hit, `max_range` when nothing is within range;
* `label`: what was hit, `LABELS` (0 nothing, 1 car, 2 pedestrian, 3 road edge);
* `ψ_r`: the hit object's heading minus the ego's, wrapped to [-π, π) (rad); for a road edge,
  the direction of the kerb segment relative to the ego's heading, folded to [-π/2, π/2);
* `v_r`: the hit object's speed minus the ego's (m/s); a road edge is still (0 − v_ego).

A ray that hits nothing reads `[max_range, 0, 0, 0]`. Road edges are the boundary of the
drivable area (kerbs to sidewalks, terrain and islands), not the edge of the map.

Noise (ch. 7): with variance λ_l > 0, zero-mean Gaussian noise of variance λ_l is added to
`d`, `ψ_r` and `v_r` of every ray (d is then clipped to [0, max_range], ψ_r wrapped to
[-π, π), v_r clipped to the space); then each ray is independently dropped, i.e. read as empty,
with probability ε. All draws come from the generator passed to `QLidarSensor.observe`.

Version 1 (`version=1`; the `lidar_version` option, the default of the FLUIDS-v1 ids) also
sees what a driver must respect, and where to go:

* the stop line of every traffic light that shows red (label 4, `red_light`) or yellow
  (label 5, `yellow_light`) is an obstacle: a segment across its lane(s) at the lane's end;
  its ψ_r is the line's direction (folded to [-π/2, π/2)), its v_r is −v_ego (it is still);
* a crosswalk with a pedestrian on it is an obstacle labelled as a pedestrian (2): its
  rectangle's edges stop rays (ψ_r the edge's direction, folded; v_r = −v_ego);
* one extra row (index m) reads the direction to the next waypoint of the ego's route, the point
  `WAYPOINT_AHEAD` metres further along its path (its goal when nearer):
  `[distance (m, at most max_range), 6 (goal), its bearing from the ego's heading (rad, in
  [-π, π)), −v_ego]`. It is exact: noise and dropout apply to the m rays only, with the same
  draws as version 0, so a v1 reading's rays differ from v0's only where v1 sees more.

Ray casting is a compiled loop (`fluids_bench.tasks.fluids.sim.sensors.kernels.qlidar_cast`): each ray
against the oriented rectangles of the agents within reach (slab test in each rectangle's frame)
and against the road-edge segments within reach (segments precomputed once per layout).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import shapely
from numba import njit

from fluids_bench.tasks.fluids.sim.crosswalks import crosswalks_of
from fluids_bench.tasks.fluids.sim.layout.compiled import Layout
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.sim.lights import CAUTION, STOP
from fluids_bench.tasks.fluids.sim.sensors.kernels import (
    qlidar_cast,
    qlidar_noise,
    qlidar_v1_extras,
)

LABELS = ("nothing", "car", "pedestrian", "road_edge")
NOTHING, CAR_HIT, PEDESTRIAN_HIT, EDGE_HIT = range(4)
LABELS_V1 = (*LABELS, "red_light", "yellow_light", "goal")  # version 1's labels
RED_LIGHT_HIT, YELLOW_LIGHT_HIT, GOAL_ROW = 4, 5, 6
WAYPOINT_AHEAD = 5.0  # m along the route to the "next waypoint" of version 1's goal row
FIELDS = ("distance", "label", "relative_angle", "relative_speed")
_LABEL_CODES = np.array([NOTHING, CAR_HIT, PEDESTRIAN_HIT, EDGE_HIT], dtype=float)


@dataclass(frozen=True, eq=False)
class RoadEdges:
    """Straight segments of a layout's drivable boundary: start `a` (S, 2), vector `e`
    (S, 2), direction (rad, folded to [-π/2, π/2)), midpoint and half-length (for culling)."""

    a: np.ndarray
    e: np.ndarray
    angle: np.ndarray
    mid: np.ndarray
    half: np.ndarray


@functools.lru_cache(maxsize=32)
def road_edges(layout: Layout) -> RoadEdges:
    """The kerb segments of `layout` (cached per layout). Segments lying on the layout's
    bounds (where roads leave the map) are left out: rays pass through the map's edge."""
    x0, y0, x1, y1 = layout.bounds
    starts, ends = [], []
    for line in shapely.get_parts(shapely.boundary(layout.drivable)):
        pts = np.asarray(line.coords)
        if len(pts) >= 2:
            starts.append(pts[:-1])
            ends.append(pts[1:])
    a = np.concatenate(starts) if starts else np.zeros((0, 2))
    b = np.concatenate(ends) if ends else np.zeros((0, 2))
    eps = 1e-6
    on_bounds = np.zeros(len(a), dtype=bool)
    for axis, value in ((0, x0), (0, x1), (1, y0), (1, y1)):
        on_bounds |= (np.abs(a[:, axis] - value) < eps) & (np.abs(b[:, axis] - value) < eps)
    keep = ~on_bounds & (np.hypot(*(b - a).T) > 1e-9)
    a, b = a[keep], b[keep]
    e = b - a
    angle = (np.arctan2(e[:, 1], e[:, 0]) + math.pi / 2) % math.pi - math.pi / 2
    edges = RoadEdges(a, e, angle, (a + b) / 2, np.hypot(*e.T) / 2)
    for arr in (edges.a, edges.e, edges.angle, edges.mid, edges.half):
        arr.setflags(write=False)
    return edges


def _fold(e: np.ndarray) -> np.ndarray:
    return (np.arctan2(e[:, 1], e[:, 0]) + math.pi / 2) % math.pi - math.pi / 2


@dataclass(frozen=True, eq=False)
class RespectGeometry:
    """What version 1 adds, per layout: stop lines (start `line_a`, vector `line_e`, folded
    direction `line_angle`, governing light `line_light`) and crosswalk rectangles (their
    four edges `cw_a`/`cw_e`/`cw_angle`, (C, 4, ...); centre, unit axis, half length and
    half width for the occupancy test)."""

    line_a: np.ndarray
    line_e: np.ndarray
    line_angle: np.ndarray
    line_light: np.ndarray
    cw_a: np.ndarray
    cw_e: np.ndarray
    cw_angle: np.ndarray
    cw_centre: np.ndarray
    cw_axis: np.ndarray
    cw_half: np.ndarray


@functools.lru_cache(maxsize=32)
def respect_geometry(layout: Layout) -> RespectGeometry:
    spec = layout.spec
    light_index = {light.name: i for i, light in enumerate(spec.lights)}
    a, e, lights = [], [], []
    for lane in spec.lanes:
        if lane.light is None:
            continue
        end = np.asarray(lane.centerline[-1], float)
        d = end - np.asarray(lane.centerline[-2], float)
        d /= np.hypot(*d)
        across = np.array([-d[1], d[0]]) * lane.width / 2
        a.append(end - across)
        e.append(2 * across)
        lights.append(light_index[lane.light])
    line_a = np.array(a).reshape(-1, 2)
    line_e = np.array(e).reshape(-1, 2)
    ca, ce = [], []
    for cw in spec.crosswalks:
        p, q = np.asarray(cw.start, float), np.asarray(cw.end, float)
        u = (q - p) / np.hypot(*(q - p))
        n = np.array([-u[1], u[0]]) * cw.width / 2
        corners = np.array([p - n, q - n, q + n, p + n])
        ca.append(corners)
        ce.append(np.roll(corners, -1, axis=0) - corners)
    cw_e = np.array(ce).reshape(-1, 4, 2)
    rects = crosswalks_of(layout)  # the occupancy test's rectangles (one definition)
    return RespectGeometry(
        line_a,
        line_e,
        _fold(line_e),
        np.array(lights, dtype=np.int64),
        np.array(ca).reshape(-1, 4, 2),
        cw_e,
        _fold(cw_e.reshape(-1, 2)).reshape(-1, 4),
        rects.centre,
        rects.axis,
        rects.half,
    )


class QLidarSensor:
    """`rays` rays of `max_range` metres; `noise_var` is λ_l and `dropout` is ε.

    `max_speed` (m/s) bounds the agents' speeds, so relative speeds lie in ±`max_speed`;
    the space allows twice that, to leave room for noise (values beyond are clipped).
    """

    def __init__(
        self,
        layout: Layout,
        rays: int = 64,
        max_range: float = 30.0,
        noise_var: float = 0.0,
        dropout: float = 0.0,
        max_speed: float = 10.0,
        version: int = 0,
    ) -> None:
        if version not in (0, 1):
            raise ValueError(f"QLidarSensor: field 'version' is {version!r}; allowed: 0 or 1")
        self.version = version
        self.rays = int(rays)
        self.max_range = float(max_range)
        self.noise_std = math.sqrt(noise_var)
        self.dropout = float(dropout)
        self.speed_bound = 2.0 * float(max_speed)
        self.offsets = 2 * math.pi * np.arange(self.rays) / self.rays  # rad from the ego heading
        self._cos, self._sin = np.cos(self.offsets), np.sin(self.offsets)
        self.edges = road_edges(layout)
        self.respect = respect_geometry(layout) if version == 1 else None
        self.labels = LABELS_V1 if version == 1 else LABELS
        self.shape = (self.rays + (version == 1), 4)
        self._rows: np.ndarray | None = None  # cast_worlds' output rows, reused between calls

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of the observation, each (m, 4) float32."""
        rows = self.shape[0]
        low = np.tile(np.array([0.0, 0.0, -math.pi, -self.speed_bound], np.float32), (rows, 1))
        high = np.tile(
            np.array([self.max_range, len(self.labels) - 1, math.pi, self.speed_bound], np.float32),
            (rows, 1),
        )
        return low, high

    def cast(self, world, ego: int = 0) -> np.ndarray:
        """The noiseless reading (m, 4) float64.

        Each ray keeps its nearest hit closer than `max_range`, the first one on ties
        (agents before road edges, then by index), and reads its attributes; a hit at exactly
        `max_range` reads as nothing.
        """
        ed = self.edges
        out = np.empty(self.shape)
        qlidar_cast(
            world.state, world.active, world.length, world.width, world.is_car, int(ego),
            self._cos, self._sin, self.max_range,
            ed.a, ed.e, ed.angle, ed.mid, ed.half, _LABEL_CODES, out,
        )  # fmt: skip
        if self.version == 1:
            self._cast_v1(world, int(ego), out)
        return out

    def _cast_v1(self, world, ego: int, out: np.ndarray) -> None:
        """Stop lines of red/yellow lights, occupied crosswalks, and the goal row (see the
        module docstring), in one compiled pass."""
        g = self.respect
        s = min(float(world.s[ego]) + WAYPOINT_AHEAD, float(world.path_len[ego]))
        goal = world.path_z[ego, min(int(round(s / PATH_SPACING)), world.path_z.shape[1] - 1)]
        qlidar_v1_extras(
            out, world.state, world.active, world.is_car, world.width, ego,
            self._cos, self._sin,
            g.line_a, g.line_e, g.line_angle, g.line_light, world.light_state, STOP, CAUTION,
            g.cw_a, g.cw_e, g.cw_angle, g.cw_centre, g.cw_axis, g.cw_half,
            _V1_LABELS, goal.real, goal.imag, self.max_range,
        )  # fmt: skip

    def cast_worlds(self, stepping: np.ndarray, worlds, lights: np.ndarray) -> np.ndarray:
        """`cast` of the ego of each world of `worlds` (a
        `WorldBatch`) where `stepping`, as rows
        (B, m, 4) in one compiled call; `lights`: each world's light states (B, L). Rows of
        the other worlds are left as they were."""
        w, rows, ed = worlds.worlds[0], worlds.rows, self.edges
        # version 0 passes version 1's tables unused (one compiled signature for both)
        g = self.respect or respect_geometry(w.layout)
        n = len(stepping)
        if self._rows is None or len(self._rows) != n:
            self._rows = np.zeros((n, *self.shape))
        goal_x, goal_y = np.zeros(n), np.zeros(n)
        if self.version == 1:  # _cast_v1's goal point, for every world at once
            s = np.minimum(rows["s"][:, 0] + WAYPOINT_AHEAD, rows["path_len"][:, 0])
            k = np.minimum(np.rint(s / PATH_SPACING), rows["path_z"].shape[2] - 1)
            goal = rows["path_z"][np.arange(n), 0, k.astype(np.int64)]
            goal_x, goal_y = goal.real.copy(), goal.imag.copy()
        qlidar_cast_worlds(
            stepping, rows["state"], rows["active"], w.length, w.width, w.is_car, self._cos,
            self._sin, self.max_range, ed.a, ed.e, ed.angle, ed.mid, ed.half, _LABEL_CODES,
            self.version == 1, g.line_a, g.line_e, g.line_angle, g.line_light, lights, STOP,
            CAUTION, g.cw_a, g.cw_e, g.cw_angle, g.cw_centre, g.cw_axis, g.cw_half, _V1_LABELS,
            goal_x, goal_y, self._rows,
        )  # fmt: skip
        return self._rows

    def observe(self, world, rng: np.random.Generator, ego: int = 0) -> np.ndarray:
        out = self.cast(world, ego)
        if self.noise_std > 0 or self.dropout > 0:
            # the draws, in this order, from the caller's generator; applied by a compiled loop
            noise = (
                rng.standard_normal((self.rays, 3)) * self.noise_std
                if self.noise_std > 0
                else _NONE
            )
            dropped = rng.random(self.rays) < self.dropout if self.dropout > 0 else _NONE_DROPPED
            qlidar_noise(out, noise, dropped, self.max_range, self.speed_bound)
        return out.astype(np.float32)


_V1_LABELS = np.array([RED_LIGHT_HIT, YELLOW_LIGHT_HIT, PEDESTRIAN_HIT, GOAL_ROW], dtype=float)
_NONE = np.zeros((0, 3))
_NONE_DROPPED = np.zeros(0, dtype=bool)


@njit(cache=True, nogil=True)
def qlidar_cast_worlds(
    stepping, state, active, length, width, is_car, cos_k, sin_k, max_range,
    edge_a, edge_e, edge_angle, edge_mid, edge_half, labels, v1,
    line_a, line_e, line_angle, line_light, light_state, stop_code, caution_code,
    cw_a, cw_e, cw_angle, cw_centre, cw_axis, cw_half, v1_labels, goal_x, goal_y, out,
):  # fmt: skip  # pragma: no cover (compiled)
    """`kernels.qlidar_cast` (and with `v1` `kernels.qlidar_v1_extras`) of agent
    0 on row `b` of the per-world arrays, into `out[b]`, where `stepping[b]`."""
    for b in range(len(stepping)):
        if stepping[b]:
            qlidar_cast(
                state[b], active[b], length, width, is_car, 0, cos_k, sin_k, max_range,
                edge_a, edge_e, edge_angle, edge_mid, edge_half, labels, out[b],
            )  # fmt: skip
            if v1:
                qlidar_v1_extras(
                    out[b], state[b], active[b], is_car, width, 0, cos_k, sin_k, line_a,
                    line_e, line_angle, line_light, light_state[b], stop_code, caution_code,
                    cw_a, cw_e, cw_angle, cw_centre, cw_axis, cw_half, v1_labels, goal_x[b],
                    goal_y[b], max_range,
                )  # fmt: skip
