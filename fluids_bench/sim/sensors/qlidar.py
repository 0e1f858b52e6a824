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

Ray casting is vectorised: all rays against all agents' oriented rectangles (slab test in each
rectangle's frame) and against the road-edge segments within range (segments precomputed once
per layout), with no Python loop over rays, agents or segments.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import shapely

from fluids_bench.sim.layout.compiled import CAR, Layout

LABELS = ("nothing", "car", "pedestrian", "road_edge")
NOTHING, CAR_HIT, PEDESTRIAN_HIT, EDGE_HIT = range(4)
FIELDS = ("distance", "label", "relative_angle", "relative_speed")


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


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (angle + math.pi) % (2 * math.pi) - math.pi


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
        self._empty = np.array([self.max_range, NOTHING, 0.0, 0.0])

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
        """The noiseless reading (m, 4) float64."""
        x, y, th, v = world.state[ego]
        ct, st = math.cos(th), math.sin(th)
        dx = ct * self._cos - st * self._sin  # ray directions in the world frame (m,)
        dy = st * self._cos + ct * self._sin
        out = np.empty((self.rays, 4))
        out[:] = self._empty
        best = np.full(self.rays, self.max_range)
        with np.errstate(divide="ignore", invalid="ignore"):
            self._hit_agents(world, ego, x, y, th, v, dx, dy, best, out)
            self._hit_edges(x, y, th, v, dx, dy, best, out)
        return out

    def _hit_agents(self, world, ego, x, y, th, v, dx, dy, best, out) -> None:
        """Slab test of every ray against every other active agent's rectangle, in its frame."""
        reach = self.max_range + np.hypot(world.length, world.width) / 2
        near = world.active & (np.hypot(world.state[:, 0] - x, world.state[:, 1] - y) <= reach)
        near[ego] = False
        others = np.flatnonzero(near)
        if not len(others):
            return
        ox, oy, oth, _ = world.state[others].T
        c, s = np.cos(oth), np.sin(oth)
        rx, ry = x - ox, y - oy
        px = c * rx + s * ry  # ray origin in each box's frame (n,)
        py = c * ry - s * rx
        ux = np.multiply.outer(dx, c) + np.multiply.outer(dy, s)  # ray directions there (m, n)
        uy = np.multiply.outer(dy, c) - np.multiply.outer(dx, s)
        hl, hw = world.length[others] / 2, world.width[others] / 2
        ix, iy = 1.0 / ux, 1.0 / uy
        t1, t2 = (-hl - px) * ix, (hl - px) * ix
        t3, t4 = (-hw - py) * iy, (hw - py) * iy
        near = np.maximum(np.minimum(t1, t2), np.minimum(t3, t4))
        far = np.minimum(np.maximum(t1, t2), np.maximum(t3, t4))
        dist = np.where((near <= far) & (far >= 0), np.maximum(near, 0.0), np.inf)
        j = dist.argmin(axis=1)
        d = dist[np.arange(self.rays), j]
        hit = d < best
        if hit.any():
            jj = others[j[hit]]
            best[hit] = d[hit]
            out[hit, 0] = d[hit]
            out[hit, 1] = np.where(world.kind[jj] == CAR, CAR_HIT, PEDESTRIAN_HIT)
            out[hit, 2] = _wrap(world.state[jj, 2] - th)
            out[hit, 3] = world.state[jj, 3] - v

    def _hit_edges(self, x, y, th, v, dx, dy, best, out) -> None:
        """Ray–segment intersection against the kerb segments that can be within range."""
        ed = self.edges
        near = np.flatnonzero(
            np.hypot(ed.mid[:, 0] - x, ed.mid[:, 1] - y) <= self.max_range + ed.half
        )
        if not len(near):
            return
        ex, ey = ed.e[near, 0], ed.e[near, 1]
        wx, wy = ed.a[near, 0] - x, ed.a[near, 1] - y
        denom = np.multiply.outer(dx, ey) - np.multiply.outer(dy, ex)  # (m, S)
        t = (wx * ey - wy * ex) / denom  # distance along the ray
        u = (np.multiply.outer(dy, wx) - np.multiply.outer(dx, wy)) / denom  # position on segment
        t = np.where((t >= 0) & (u >= 0) & (u <= 1), t, np.inf)
        j = t.argmin(axis=1)
        d = t[np.arange(self.rays), j]
        hit = d < best
        if hit.any():
            best[hit] = d[hit]
            out[hit, 0] = d[hit]
            out[hit, 1] = EDGE_HIT
            out[hit, 2] = (ed.angle[near[j[hit]]] - th + math.pi / 2) % math.pi - math.pi / 2
            out[hit, 3] = -v

    def observe(self, world, rng: np.random.Generator, ego: int = 0) -> np.ndarray:
        out = self.cast(world, ego)
        if self.noise_std > 0:
            noise = rng.standard_normal((self.rays, 3)) * self.noise_std
            out[:, 0] = np.clip(out[:, 0] + noise[:, 0], 0.0, self.max_range)
            out[:, 2] = _wrap(out[:, 2] + noise[:, 1])
            out[:, 3] = np.clip(out[:, 3] + noise[:, 2], -self.speed_bound, self.speed_bound)
        if self.dropout > 0:
            out[rng.random(self.rays) < self.dropout] = self._empty
        return out.astype(np.float32)
