"""Raster drawing shared by every task's pictures: world metres → OpenCV fixed-point pixels.

OpenCV draws polygons and lines with sub-pixel accuracy when given integer coordinates with
`SHIFT` fractional bits; drawing straight at the observation size this way is far cheaper
than drawing large and resizing. Pixel convention: pixel `(row, col)` is centred at `u = col`,
`v = row`, with `u` to the east and `v` to the south (world `y` points up the image).
"""

from __future__ import annotations

import cv2
import numpy as np

SHIFT = 4  # fractional bits of the fixed-point pixel coordinates passed to OpenCV
ONE = 1 << SHIFT


def to_fixed(affine: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """World points (..., 2) through the 2×3 `affine` to OpenCV fixed-point pixels (int32)."""
    flat = cv2.transform(
        np.ascontiguousarray(pts, dtype=np.float64).reshape(-1, 1, 2), affine * ONE
    )
    return np.rint(flat).astype(np.int32).reshape(pts.shape)


def pixel_affine(ppm: float, x0: float, y1: float) -> np.ndarray:
    """World → pixel map of a raster whose top-left corner is world (x0, y1)."""
    return np.array([[ppm, 0.0, -x0 * ppm - 0.5], [0.0, -ppm, y1 * ppm - 0.5]])


def line_px(ppm: float, metres: float) -> int:
    """A line thickness in whole pixels, at least 1."""
    return max(1, int(round(metres * ppm)))


CORNER_SIGNS = np.array([1 + 1j, 1 - 1j, -1 - 1j, -1 + 1j]) / 2  # (±length, ±width) halves


def boxes_px(affine, x, y, th, length, width) -> np.ndarray:
    """Fixed-point pixel corners (n, 4, 2) of rectangles centred at world (x, y), `length` m
    along heading `th`, `width` m across (all (n,) arrays). Complex arithmetic: a corner is
    `x + iy + e^{iθ}(±l ± iw)/2`, few numpy calls for any n."""
    local = length[:, None] * CORNER_SIGNS.real + 1j * (width[:, None] * CORNER_SIGNS.imag)
    z = np.exp(1j * th)[:, None] * local
    z += (x + 1j * y)[:, None]
    return to_fixed(affine, z.view(np.float64).reshape(len(x), 4, 2))
