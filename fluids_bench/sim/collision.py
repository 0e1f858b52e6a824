"""Collision checking with Shapely 2's vectorised API: one STRtree query per step, no pair loop.

Kinds logged: ``car-car``, ``car-pedestrian`` and ``offroad`` (a car's footprint leaves the
drivable area, i.e. touches terrain or a sidewalk). Pedestrians brushing past each other is not
a collision.
"""

from __future__ import annotations

import numpy as np
import shapely

OFFROAD_TOLERANCE = 0.25  # m a footprint may overhang the kerb (a wheel on the kerb line)
KINDS = ("car-car", "car-pedestrian", "offroad")


def footprint_corners(x, y, theta, length, width) -> np.ndarray:
    """Corners (N, 4, 2) of rectangles centred at (x, y), ``length`` along heading ``theta``."""
    c, s = np.cos(theta), np.sin(theta)
    hl, hw = length / 2.0, width / 2.0
    lx = np.array([1.0, 1.0, -1.0, -1.0])
    ly = np.array([1.0, -1.0, -1.0, 1.0])
    px = lx[None, :] * hl[:, None]
    py = ly[None, :] * hw[:, None]
    return np.stack([x[:, None] + c[:, None] * px - s[:, None] * py,
                     y[:, None] + s[:, None] * px + c[:, None] * py], axis=-1)


def find_collisions(corners: np.ndarray, is_car: np.ndarray, drivable_tolerant) -> list[tuple[int, int, str]]:
    """Every colliding pair ``(i, j, kind)`` with i < j, and ``(i, -1, "offroad")`` for cars.

    ``corners`` are the footprints of the agents to check (indices refer to its rows);
    ``drivable_tolerant`` is the prepared drivable area grown by :data:`OFFROAD_TOLERANCE`.
    """
    if len(corners) == 0:
        return []
    polys = shapely.polygons(corners)
    tree = shapely.STRtree(polys)
    a, b = tree.query(polys, predicate="intersects")
    keep = (a < b) & (is_car[a] | is_car[b])
    out = [(int(i), int(j), "car-car" if is_car[i] and is_car[j] else "car-pedestrian")
           for i, j in zip(a[keep], b[keep], strict=True)]
    cars = np.flatnonzero(is_car)
    if len(cars):
        inside = shapely.within(polys[cars], drivable_tolerant)
        out.extend((int(i), -1, "offroad") for i in cars[~inside])
    return out
