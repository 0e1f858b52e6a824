"""Collision checking: a compiled broad phase, then Shapely 2's vectorised predicates.

Kinds logged: `car-car`, `car-pedestrian` and `offroad` (a car's footprint leaves the
drivable area, i.e. touches terrain or a sidewalk). Pedestrians brushing past each other is not
a collision.

Pairs are first culled by covering circles (three along each car, one per pedestrian: they
contain the footprint, so disjoint circles prove no contact) in one compiled loop over all
pairs (`fluids_bench.tasks.fluids.sim.kernels.touching_pairs`); only pairs whose circles meet become
Shapely polygons, tested with one array call of `shapely.intersects`. At the scene sizes
FLUIDS runs (tens of agents) this beats building an STRtree every step;
`find_collisions_strtree` is the tree-based equivalent, used by the tests as a reference. Off-road is exact without building polygons: a rectangle lies inside
the (slightly grown) drivable area iff its four corners do (one `contains_xy` call) and no
vertex of that area's boundary lies inside the rectangle (the only way the boundary can cut in
between inside corners).
"""

from __future__ import annotations

import numpy as np
import shapely

from fluids_bench.tasks.fluids.sim import kernels

OFFROAD_TOLERANCE = 0.25  # m a footprint may overhang the kerb (a wheel on the kerb line)
KINDS = ("car-car", "car-pedestrian", "offroad")
# corners of a footprint, in units of (half length, half width)
_CORNERS = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]], float)


def footprint_corners(x, y, theta, length, width) -> np.ndarray:
    """Corners (N, 4, 2) of rectangles centred at (x, y), `length` along heading `theta`."""
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    px = _CORNERS[None, :, 0] * (length / 2)[:, None]
    py = _CORNERS[None, :, 1] * (width / 2)[:, None]
    return np.stack([x[:, None] + c * px - s * py, y[:, None] + s * px + c * py], axis=-1)


def _kinds(a: np.ndarray, b: np.ndarray, is_car: np.ndarray) -> list[tuple[int, int, str]]:
    return [
        (int(i), int(j), "car-car" if is_car[i] and is_car[j] else "car-pedestrian")
        for i, j in zip(a, b, strict=True)
    ]


def find_collisions(
    state: np.ndarray,
    length: np.ndarray,
    width: np.ndarray,
    is_car: np.ndarray,
    active: np.ndarray,
    drivable_tolerant,
    boundary: np.ndarray,
    offroad_candidates: np.ndarray | None = None,
) -> list[tuple[int, int, str]]:
    """Every colliding pair `(i, j, kind)` with i < j among `active` agents, and
    `(i, -1, "offroad")` for active cars.

    `state` (N, 4) holds [x, y, θ, v]; `drivable_tolerant` is the prepared drivable area
    grown by `OFFROAD_TOLERANCE` and `boundary` its boundary's vertices (complex).
    `offroad_candidates` (bool, N) limits the off-road test to the cars the caller cannot
    vouch for (default: every active car).
    """
    n = len(state)
    out: list[tuple[int, int, str]] = []
    state = np.ascontiguousarray(state, dtype=np.float64)
    circles = covering_circles(is_car, length, width)
    a, b = kernels.touching_pairs(state, np.asarray(active, dtype=bool), *circles)
    if len(a):
        involved = np.unique(np.concatenate([a, b]))
        corners = footprint_corners(
            state[involved, 0],
            state[involved, 1],
            state[involved, 2],
            length[involved],
            width[involved],
        )
        polys = np.empty(n, dtype=object)
        polys[involved] = shapely.polygons(corners)
        hit = shapely.intersects(polys[a], polys[b])
        out.extend(_kinds(a[hit], b[hit], is_car))
    cars = (is_car & active if offroad_candidates is None else offroad_candidates).nonzero()[0]
    if len(cars):
        hl, hw = length[cars, None] / 2, width[cars, None] / 2
        centre = state.view(np.complex128)[cars, 0]  # x + iy
        heading = np.exp(1j * state[cars, 2])
        corners = centre[:, None] + heading[:, None] * (
            _CORNERS_C.real * hl + 1j * _CORNERS_C.imag * hw
        )
        inside = shapely.contains_xy(drivable_tolerant, corners.real.ravel(), corners.imag.ravel())
        off = ~inside.reshape(len(cars), -1).all(axis=1)
        local = (boundary[None, :] - centre[:, None]) * heading[:, None].conj()  # car frames
        off |= ((np.abs(local.real) < hl) & (np.abs(local.imag) < hw)).any(axis=1)
        out.extend((int(i), -1, "offroad") for i in cars[off])
    return out


_CORNERS_C = _CORNERS[:, 0] + 1j * _CORNERS[:, 1]
_COVERING_CIRCLES: dict[bytes, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def covering_circles(
    is_car: np.ndarray, length: np.ndarray, width: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The broad phase's geometry, cached per agent make-up: (N, N) squared sum of circumscribed
    radii for pairs i < j with at least one car (-1 for the others, so no distance passes), and
    the covering circles (offsets (N, 3) m along the heading at -1/3, 0, +1/3 of a car's
    length; radius (N,) m; one circle per pedestrian)."""
    key = is_car.tobytes() + length.tobytes() + width.tobytes()
    if key not in _COVERING_CIRCLES:
        half_diag = 0.5 * np.hypot(length, width)
        reach = half_diag[:, None] + half_diag[None, :]
        pairs = np.triu(is_car[:, None] | is_car[None, :], k=1)
        offsets = np.outer(np.where(is_car, length / 3, 0.0), [-1.0, 0.0, 1.0])
        radius = np.hypot(np.where(is_car, length / 6, length / 2), width / 2)
        _COVERING_CIRCLES[key] = (np.where(pairs, reach * reach, -1.0), offsets, radius)
    return _COVERING_CIRCLES[key]


def find_collisions_strtree(
    state, length, width, is_car, active, drivable_tolerant
) -> list[tuple[int, int, str]]:
    """Reference implementation with an STRtree and exact polygon containment (tests use it)."""
    idx = active.nonzero()[0]
    found = _strtree(state[idx], length[idx], width[idx], is_car[idx], drivable_tolerant)
    return [(int(idx[a]), int(idx[b]) if b >= 0 else -1, kind) for a, b, kind in found]


def _strtree(state, length, width, is_car, drivable_tolerant) -> list[tuple[int, int, str]]:
    x, y, th = state[:, 0], state[:, 1], state[:, 2]
    polys = shapely.polygons(footprint_corners(x, y, th, length, width))
    a, b = shapely.STRtree(polys).query(polys, predicate="intersects")
    keep = (a < b) & (is_car[a] | is_car[b])
    out = _kinds(a[keep], b[keep], is_car)
    cars = np.flatnonzero(is_car)
    inside = shapely.within(polys[cars], drivable_tolerant)
    out.extend((int(i), -1, "offroad") for i in cars[~inside])
    return out
