"""Overhead pictures of the singulation world (the source's webcam view), drawn with OpenCV.

Drawn straight at the requested size in fixed-point coordinates (fluids_bench.core.raster):
table, arm link, fingertip and the four objects. Drawing only reads the world.
"""

from __future__ import annotations

import cv2
import numpy as np

from fluids_bench.core import raster
from fluids_bench.tasks.singulation.sim import TIP_RADIUS, SingulationWorld, object_polygon

# the square the camera sees (m): the whole reachable cluster region and the arm base
VIEW_X0, VIEW_Y1, VIEW_SIZE = -0.4, 0.8, 0.8
TABLE = (206, 190, 160)  # RGB: light wood
OBJECT_COLOURS = ((200, 40, 40), (220, 90, 40), (170, 30, 70), (230, 60, 90))  # reds, as MDF
LINK = (90, 90, 90)
TIP = (30, 30, 30)


def draw(world: SingulationWorld, size: int, out: np.ndarray | None = None) -> np.ndarray:
    """An RGB uint8 image (size, size, 3) of the table seen from above (+y up the image)."""
    ppm = size / VIEW_SIZE
    affine = raster.pixel_affine(ppm, VIEW_X0, VIEW_Y1)
    img = np.empty((size, size, 3), np.uint8) if out is None else out
    img[:] = TABLE
    scale = world.config.object_size_scale
    for i, (x, y, a) in enumerate(world.poses()):
        pts = raster.to_fixed(affine, object_polygon(i, x, y, a, scale))
        cv2.fillPoly(img, [pts], OBJECT_COLOURS[i], cv2.LINE_AA, raster.SHIFT)
    base, tip = raster.to_fixed(affine, np.array([[0.0, 0.0], world.tip_xy()]))
    cv2.line(img, base, tip, LINK, raster.line_px(ppm, 0.008), cv2.LINE_AA, raster.SHIFT)
    radius = max(raster.ONE, int(round(TIP_RADIUS * ppm * raster.ONE)))
    cv2.circle(img, tip, radius, TIP, -1, cv2.LINE_AA, raster.SHIFT)
    return img
