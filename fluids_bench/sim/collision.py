"""Collision checking: a numpy broad phase, then Shapely 2's vectorised predicates.

Kinds logged: ``car-car``, ``car-pedestrian`` and ``offroad`` (a car's footprint leaves the
drivable area, i.e. touches terrain or a sidewalk). Pedestrians brushing past each other is not
a collision.

Pairs are first culled by covering circles (three along each car, one per pedestrian: they
contain the footprint, so disjoint circles prove no contact) in one array expression over all
pairs; only pairs whose circles meet become Shapely polygons, tested with one array call of
``shapely.intersects``. At the scene sizes FLUIDS runs (tens of agents) this beats building an
STRtree every step; :func:`find_collisions_strtree` is the tree-based equivalent, used by the
tests as a reference. Off-road is one ``contains_xy`` call on probe points of every car
(corners and edge midpoints) against the prepared, slightly grown drivable area.
"""

from __future__ import annotations

import numpy as np
import shapely

OFFROAD_TOLERANCE = 0.25  # m a footprint may overhang the kerb (a wheel on the kerb line)
KINDS = ("car-car", "car-pedestrian", "offroad")
# probe points of a footprint, in units of (half length, half width)
_PROBES = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1], [1, 0], [0, 1], [0, -1], [-1, 0]], float)


def footprint_corners(x, y, theta, length, width) -> np.ndarray:
    """Corners (N, 4, 2) of rectangles centred at (x, y), ``length`` along heading ``theta``."""
    return footprint_points(x, y, theta, length, width, _PROBES[:4])


def footprint_points(x, y, theta, length, width, unit=_PROBES) -> np.ndarray:
    """Points (N, P, 2) of footprints at ``unit`` offsets (half-length, half-width units)."""
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    px = unit[None, :, 0] * (length / 2)[:, None]
    py = unit[None, :, 1] * (width / 2)[:, None]
    return np.stack([x[:, None] + c * px - s * py, y[:, None] + s * px + c * py], axis=-1)


def _kinds(a: np.ndarray, b: np.ndarray, is_car: np.ndarray) -> list[tuple[int, int, str]]:
    return [(int(i), int(j), "car-car" if is_car[i] and is_car[j] else "car-pedestrian")
            for i, j in zip(a, b, strict=True)]


def find_collisions(state: np.ndarray, length: np.ndarray, width: np.ndarray, is_car: np.ndarray,
                    drivable_tolerant) -> list[tuple[int, int, str]]:
    """Every colliding pair ``(i, j, kind)`` with i < j, and ``(i, -1, "offroad")`` for cars.

    ``state`` (N, 4) holds [x, y, θ, v] of the agents to check (indices refer to its rows);
    ``drivable_tolerant`` is the prepared drivable area grown by :data:`OFFROAD_TOLERANCE`.
    """
    n = len(state)
    out: list[tuple[int, int, str]] = []
    if n == 0:
        return out
    x, y, th = state[:, 0], state[:, 1], state[:, 2]
    if n > 1:
        # three covering circles per agent, centred at -1/3, 0, +1/3 of the length
        step = np.where(is_car, length / 3, 0.0)
        radius = np.hypot(np.where(is_car, length / 6, length / 2), width / 2)
        centre = x + 1j * y
        circles = centre[:, None] + np.outer(step * np.exp(1j * th), (-1.0, 0.0, 1.0))
        d = np.abs(circles[:, None, :, None] - circles[None, :, None, :]).min(axis=(2, 3))
        near = d < radius[:, None] + radius[None, :]
        a, b = np.nonzero(np.triu(near, k=1) & (is_car[:, None] | is_car[None, :]))
        if len(a):
            corners = footprint_corners(x, y, th, length, width)
            polys = shapely.polygons(corners)
            hit = shapely.intersects(polys[a], polys[b])
            out.extend(_kinds(a[hit], b[hit], is_car))
    cars = np.flatnonzero(is_car)
    if len(cars):
        pts = footprint_points(x[cars], y[cars], th[cars], length[cars], width[cars])
        inside = shapely.contains_xy(drivable_tolerant, pts[..., 0].ravel(), pts[..., 1].ravel())
        off = ~inside.reshape(len(cars), -1).all(axis=1)
        out.extend((int(i), -1, "offroad") for i in cars[off])
    return out


def find_collisions_strtree(state, length, width, is_car, drivable_tolerant) -> list[tuple[int, int, str]]:
    """Reference implementation with an STRtree and exact polygon containment."""
    x, y, th = state[:, 0], state[:, 1], state[:, 2]
    polys = shapely.polygons(footprint_corners(x, y, th, length, width))
    a, b = shapely.STRtree(polys).query(polys, predicate="intersects")
    keep = (a < b) & (is_car[a] | is_car[b])
    out = _kinds(a[keep], b[keep], is_car)
    cars = np.flatnonzero(is_car)
    inside = shapely.within(polys[cars], drivable_tolerant)
    out.extend((int(i), -1, "offroad") for i in cars[~inside])
    return out
