"""Overhead RGB pictures of the grasping world, drawn with OpenCV straight at the output size.

Only reads the world's state. The picture covers the table with a margin (the arm's base sits on
the near edge, at the bottom of the image): grey floor, light table, green target, red obstacles,
the arm in dark blue and the fingers in orange. Knocked-off objects are not drawn.
"""

from __future__ import annotations

import cv2
import numpy as np

from fluids_bench.core.raster import ONE, SHIFT, boxes_px, line_px, pixel_affine, to_fixed
from fluids_bench.tasks.grasping.sim import TARGET, GraspConfig, WorldState, forward

FLOOR = (70, 70, 70)
TABLE = (205, 200, 190)
TARGET_RGB = (40, 170, 60)
OBSTACLE_RGB = (200, 45, 45)
ARM_RGB = (40, 60, 140)
FINGER_RGB = (235, 140, 30)
MARGIN = 0.05  # m of floor around the table


def view(cfg: GraspConfig, size: int) -> tuple[np.ndarray, float]:
    """World → pixel affine map of a `size`² picture of the table, and pixels per metre."""
    span = max(cfg.table_width, cfg.table_depth + 0.08) + 2 * MARGIN
    ppm = size / span
    cx = 0.0
    cy = (cfg.table_depth - 0.08) / 2  # the base (y = 0) stays inside the picture
    return pixel_affine(ppm, cx - span / 2, cy + span / 2), ppm


def draw(cfg: GraspConfig, st: WorldState, size: int) -> np.ndarray:
    """An RGB `(size, size, 3)` uint8 overhead picture of the state."""
    affine, ppm = view(cfg, size)
    image = np.empty((size, size, 3), dtype=np.uint8)
    image[:] = FLOOR
    half = cfg.table_width / 2
    table = np.array([(-half, 0.0), (half, 0.0), (half, cfg.table_depth), (-half, cfg.table_depth)])
    cv2.fillPoly(image, [to_fixed(affine, table)], TABLE, cv2.LINE_AA, SHIFT)
    on = np.flatnonzero(st.on_table)
    if len(on):
        p = st.poses[on]
        corners = boxes_px(affine, p[:, 0], p[:, 1], p[:, 2], st.sizes[on, 0], st.sizes[on, 1])
        for k, i in enumerate(on):
            colour = TARGET_RGB if i == TARGET else OBSTACLE_RGB
            cv2.fillPoly(image, [corners[k]], colour, cv2.LINE_AA, SHIFT)
    _draw_arm(image, affine, ppm, cfg, st)
    return image


def _draw_arm(image, affine, ppm, cfg: GraspConfig, st: WorldState) -> None:
    pts, heading = forward(cfg, st.q)
    c, s = np.cos(heading), np.sin(heading)
    gap = cfg.gap_open - st.gripper * (cfg.gap_open - cfg.gap_closed)
    off = gap / 2 + cfg.finger_radius
    palm = np.array(pts[3])
    normal = np.array([-s, c])
    axis = np.array([c, s])
    half_palm = cfg.gap_open / 2 + 2 * cfg.finger_radius
    segments = [
        (pts[0], pts[1], cfg.link_radius, ARM_RGB),
        (pts[1], pts[2], cfg.link_radius, ARM_RGB),
        (pts[2], pts[3], cfg.link_radius, ARM_RGB),
        (palm - half_palm * normal, palm + half_palm * normal, cfg.finger_radius, ARM_RGB),
    ]
    for sign in (1.0, -1.0):
        base = palm + sign * off * normal
        segments.append((base, base + cfg.finger_length * axis, cfg.finger_radius, FINGER_RGB))
    for a, b, radius, colour in segments:
        ends = to_fixed(affine, np.array([a, b], dtype=np.float64))
        thickness = line_px(ppm, 2 * radius)
        cv2.line(image, tuple(ends[0]), tuple(ends[1]), colour, thickness, cv2.LINE_AA, SHIFT)
    base_px = to_fixed(affine, np.array([[0.0, 0.0]]))[0]
    radius_px = max(ONE, int(round(0.025 * ppm * ONE)))
    cv2.circle(image, tuple(base_px), radius_px, ARM_RGB, -1, cv2.LINE_AA, SHIFT)
