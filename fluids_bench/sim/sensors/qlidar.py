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

    Speed: the arrays are small, so numpy's per-call overhead is the cost, and it is several
    times higher for a broadcasting operation than for one on equal shapes. So what is static
    is laid out once (per layout, per world's agents), each family of products comes from one
    broadcast into a stacked array, and the rest runs on equal shapes. Every value is the same
    IEEE operation on the same operands as in the formulas given in the comments (a + (−b) is
    a − b, x + (−0.0) is x), so the reading does not depend on this arrangement.
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
        c, s = np.cos(self.offsets), np.sin(self.offsets)
        # cos θ · _trig[0] + sin θ · _trig[1] is [[dx, dy], [−dx, dy]] (2, 2, m) for a heading θ:
        # the ray directions (dx = cos θ c − sin θ s, dy = sin θ c + cos θ s) and −dx
        self._trig = np.array([[[c, s], [-c, s]], [[-s, c], [s, c]]])
        self.edges = ed = road_edges(layout)
        self._mid = ed.mid.T.copy()
        self._seg_reach = self.max_range + ed.half  # a segment is near if its midpoint is closer
        # per segment (rows, gathered with one call): ey, −ex, ay, ax, then its attributes
        # [label, angle, speed, half period, period] (see cast)
        n = len(ed.a)
        self._segs = np.vstack(
            [
                ed.e[:, 1],
                -ed.e[:, 0],
                ed.a[:, 1],
                ed.a[:, 0],
                np.full(n, EDGE_HIT),
                ed.angle,
                np.full(n, -0.0),
                np.full(n, math.pi / 2),
                np.full(n, math.pi),
            ]
        )
        self.shape = (self.rays, 4)
        self._empty = np.array([self.max_range, NOTHING, 0.0, 0.0])
        self._ray_index = np.arange(self.rays)
        self._agents = (None, None)  # (world.length it was built for, per-agent buffer)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of the observation, each (m, 4) float32."""
        low = np.tile(np.array([0.0, 0.0, -math.pi, -self.speed_bound], np.float32), (self.rays, 1))
        high = np.tile(
            np.array([self.max_range, len(LABELS) - 1, math.pi, self.speed_bound], np.float32),
            (self.rays, 1),
        )
        return low, high

    def _agent_buffer(self, world) -> np.ndarray:
        """A row per agent, built once per world's agents and refreshed on each cast: centre
        relative to the ego (2), attributes [label, heading, speed, half period, period] (5),
        −l/2, −w/2, l/2, w/2 (4) and reach (m; a centre farther away cannot be hit)."""
        if self._agents[0] is not world.length:
            hl, hw = world.length / 2, world.width / 2
            n = len(hl)
            buf = np.column_stack(
                [
                    np.zeros((n, 2)),
                    np.where(world.kind == CAR, CAR_HIT, PEDESTRIAN_HIT),
                    np.zeros((n, 2)),
                    np.full(n, math.pi),
                    np.full(n, 2 * math.pi),
                    -hl,
                    -hw,
                    hl,
                    hw,
                    self.max_range + np.hypot(world.length, world.width) / 2,
                ]
            )
            self._agents = (world.length, buf)
        return self._agents[1]

    def cast(self, world, ego: int = 0) -> np.ndarray:
        """The noiseless reading (m, 4) float64.

        Every ray is tested against every nearby agent and kerb segment at once, filling a
        (1 + agents + segments, rays) matrix of hit distances: ``max_range`` in the first row
        (nothing), inf for a miss. Each ray keeps its smallest entry, the first one on ties (so
        nothing at exactly ``max_range``, agents before segments, then by index), and reads that
        row's attributes.
        """
        state = world.state
        x, y, th, v = state[ego].tolist()
        d = math.cos(th) * self._trig[0] + math.sin(th) * self._trig[1]  # [[dx, dy], [−dx, dy]]
        buf = self._agent_buffer(world)
        np.subtract(state[:, :2], state[ego, :2], out=buf[:, :2])
        buf[:, 3:5] = state[:, 2:]
        near = world.active & (np.hypot(buf[:, 0], buf[:, 1]) <= buf[:, 11])
        near[ego] = False
        agents = buf[near]
        segs = self._segs[:, np.hypot(self._mid[0] - x, self._mid[1] - y) <= self._seg_reach]
        with np.errstate(divide="ignore", invalid="ignore"):
            dist = np.concatenate(
                [
                    np.full((1, self.rays), self.max_range),
                    self._hit_agents(d[0], agents),
                    self._hit_edges(x, y, d, segs),
                ]
            )
        j = dist.argmin(axis=0)
        attrs = np.concatenate(
            [[(NOTHING, th, v, math.pi, 2 * math.pi)], agents[:, 2:7], segs[4:].T]
        )[j]
        out = np.empty((self.rays, 4))
        out[:, 0] = dist[j, self._ray_index]
        out[:, 1] = attrs[:, 0]
        # relative angle: (heading − θ) wrapped to [−π, π) for agents, (angle − θ) folded to
        # [−π/2, π/2) for segments; 0 for nothing (its "heading" is θ)
        a = out[:, 2]
        np.subtract(attrs[:, 1], th, out=a)
        a += attrs[:, 3]
        a %= attrs[:, 4]
        a -= attrs[:, 3]
        # relative speed: speed − v (nothing's speed is v, a segment's −0.0, so that gives −v)
        np.subtract(attrs[:, 2], v, out=out[:, 3])
        return out

    def _hit_agents(self, d, agents) -> np.ndarray:
        """Distances (n, m) along the rays ``d`` to the rectangles of ``agents`` (rows of the
        agent buffer), inf for a miss: a slab test in each rectangle's frame."""
        n = len(agents)
        cs = np.empty((2, 2, n, 1))  # [[c, s], [−s, c]] of each agent's heading
        np.cos(agents[:, 3], out=cs[0, 0, :, 0])
        np.sin(agents[:, 3], out=cs[0, 1, :, 0])
        np.negative(cs[0, 1], out=cs[1, 0])
        cs[1, 1] = cs[0, 0]
        # the centre in its own frame, [c rx + s ry, c ry − s rx] for r = centre − ray origin ...
        pp = cs[..., 0] * agents[:, :2].T
        # ... so the slabs, [[−l/2, −w/2], [l/2, w/2]] around it, relative to the ray origin
        slabs = agents[:, 7:11].T.reshape(2, 2, n) + (pp[:, 0] + pp[:, 1])
        # ray directions in each agent's frame: [c dx + s dy, c dy − s dx] (2, n, m)
        uu = cs * d[:, None]
        u = uu[:, 0] + uu[:, 1]
        t = slabs[..., None] * (1.0 / u)  # [[t1, t3], [t2, t4]]: slab crossings
        lo, hi = np.minimum(t[0], t[1]), np.maximum(t[0], t[1])
        near, far = np.maximum(lo[0], lo[1]), np.minimum(hi[0], hi[1])
        # a hit where the ray is inside both slabs at once, ahead of its origin: near ≤ far and
        # far ≥ 0, that is max(near, 0) ≤ far (false with a NaN, as each comparison is)
        near = np.maximum(near, 0.0)
        return np.where(near <= far, near, np.inf)

    def _hit_edges(self, x, y, d, segs) -> np.ndarray:
        """Distances (S, m) along the rays ``d`` to the kerb segments ``segs`` (columns of
        :attr:`_segs`), inf for a miss. With w = start − ray origin and e the segment's
        vector, a ray crosses the segment's line at t = (w × e) / (d × e) along it and
        u = (w × d) / (d × e) along the segment."""
        rows = segs[:4] + np.array([[-0.0], [-0.0], [-y], [-x]])  # [ey, −ex, wy, wx]
        ey, nex, wy, wx = rows
        # [[dx ey, dy (−ex)], [(−dx) wy, dy wx]] summed: [d × e, w × d] (2, S, m); −dx is
        # cos θ (−c) + sin θ s, which may be +0.0 where dx is, but that changes only the sign of
        # a zero u, and u is only compared with 0 and 1
        pair = rows.reshape(2, 2, -1, 1) * d[:, :, None]
        cross = pair[:, 0] + pair[:, 1]
        t = (wx * ey + wy * nex)[:, None] / cross[0]  # distance along the ray
        u = cross[1] / cross[0]  # position on the segment
        # t ≥ 0 and 0 ≤ u ≤ 1 (false with a NaN, as each comparison is)
        return np.where((np.minimum(t, u) >= 0) & (u <= 1), t, np.inf)

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
