"""The quasi-LIDAR observation of ch. 7: ``m`` rays around the ego, each reporting what it hits.

Ray ``k`` (k = 0 … m−1) leaves the ego's centre at angle ``θ_ego + 2πk/m`` (counter-clockwise,
ray 0 straight ahead; equal spacing over 360° with no duplicated ray at ±180°). Each ray reads a
row ``[d, label, ψ_r, v_r]`` of the float32 observation of shape (m, 4):

* ``d``: distance (m) to the nearest hit, ``max_range`` when nothing is within range;
* ``label``: what was hit, :data:`LABELS` (0 nothing, 1 car, 2 pedestrian, 3 road edge);
* ``ψ_r``: the hit object's heading minus the ego's, wrapped to [-π, π) (rad); for a road edge,
  the direction of the kerb segment relative to the ego's heading, folded to [-π/2, π/2);
* ``v_r``: the hit object's speed minus the ego's (m/s); a road edge is still (0 − v_ego).

A ray that hits nothing reads ``[max_range, 0, 0, 0]``. Road edges are the boundary of the
drivable area (kerbs to sidewalks, terrain and islands), not the edge of the map.

Noise (ch. 7): with variance λ_l > 0, zero-mean Gaussian noise of variance λ_l is added to
``d``, ``ψ_r`` and ``v_r`` of every ray (d is then clipped to [0, max_range], ψ_r wrapped to
[-π, π), v_r clipped to the space); then each ray is independently dropped, i.e. read as empty,
with probability ε. All draws come from the generator passed to :meth:`QLidarSensor.observe`.

Ray casting is a compiled loop (:func:`fluids_bench.tasks.fluids.sim.sensors.kernels.qlidar_cast`): each ray
against the oriented rectangles of the agents within reach (slab test in each rectangle's frame)
and against the road-edge segments within reach (segments precomputed once per layout).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import shapely

from fluids_bench.tasks.fluids.sim.layout.compiled import Layout
from fluids_bench.tasks.fluids.sim.sensors.kernels import qlidar_cast, qlidar_noise

LABELS = ("nothing", "car", "pedestrian", "road_edge")
NOTHING, CAR_HIT, PEDESTRIAN_HIT, EDGE_HIT = range(4)
FIELDS = ("distance", "label", "relative_angle", "relative_speed")
_LABEL_CODES = np.array([NOTHING, CAR_HIT, PEDESTRIAN_HIT, EDGE_HIT], dtype=float)


@dataclass(frozen=True, eq=False)
class RoadEdges:
    """Straight segments of a layout's drivable boundary: start ``a`` (S, 2), vector ``e``
    (S, 2), direction (rad, folded to [-π/2, π/2)), midpoint and half-length (for culling)."""

    a: np.ndarray
    e: np.ndarray
    angle: np.ndarray
    mid: np.ndarray
    half: np.ndarray


@functools.lru_cache(maxsize=32)
def road_edges(layout: Layout) -> RoadEdges:
    """The kerb segments of ``layout`` (cached per layout). Segments lying on the layout's
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


class QLidarSensor:
    """``rays`` rays of ``max_range`` metres; ``noise_var`` is λ_l and ``dropout`` is ε.

    ``max_speed`` (m/s) bounds the agents' speeds, so relative speeds lie in ±``max_speed``;
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
    ) -> None:
        self.rays = int(rays)
        self.max_range = float(max_range)
        self.noise_std = math.sqrt(noise_var)
        self.dropout = float(dropout)
        self.speed_bound = 2.0 * float(max_speed)
        self.offsets = 2 * math.pi * np.arange(self.rays) / self.rays  # rad from the ego heading
        self._cos, self._sin = np.cos(self.offsets), np.sin(self.offsets)
        self.edges = road_edges(layout)
        self.shape = (self.rays, 4)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of the observation, each (m, 4) float32."""
        low = np.tile(np.array([0.0, 0.0, -math.pi, -self.speed_bound], np.float32), (self.rays, 1))
        high = np.tile(
            np.array([self.max_range, len(LABELS) - 1, math.pi, self.speed_bound], np.float32),
            (self.rays, 1),
        )
        return low, high

    def cast(self, world, ego: int = 0) -> np.ndarray:
        """The noiseless reading (m, 4) float64.

        Each ray keeps its nearest hit closer than ``max_range``, the first one on ties
        (agents before road edges, then by index), and reads its attributes; a hit at exactly
        ``max_range`` reads as nothing.
        """
        ed = self.edges
        out = np.empty((self.rays, 4))
        return qlidar_cast(
            world.state, world.active, world.length, world.width, world.is_car, int(ego),
            self._cos, self._sin, self.max_range,
            ed.a, ed.e, ed.angle, ed.mid, ed.half, _LABEL_CODES, out,
        )  # fmt: skip

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


_NONE = np.zeros((0, 3))
_NONE_DROPPED = np.zeros(0, dtype=bool)
