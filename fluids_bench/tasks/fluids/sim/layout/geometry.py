"""Curve helpers for layouts: de Casteljau Bézier evaluation and uniform arc-length resampling.

Every path in FLUIDS (lanes, routes, pedestrian walks, recovery paths) is stored resampled at a
fixed arc-length spacing, so that "position at arc length s" is an index computation instead of
a search. That is what lets the velocity planner project all agents at once.
"""

from __future__ import annotations

import numpy as np

PATH_SPACING = 0.5  # m between consecutive samples of every stored path


def de_casteljau(control: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Evaluate the Bézier curve with `control` points (n, 2) at parameters `t` (m,).

    De Casteljau's algorithm: repeated linear interpolation between neighbouring control
    points, vectorised over all parameters at once. Returns (m, 2).
    """
    pts = np.broadcast_to(control, (len(t), *control.shape)).astype(float)
    tt = t[:, None, None]
    while pts.shape[1] > 1:
        pts = (1.0 - tt) * pts[:, :-1] + tt * pts[:, 1:]
    return pts[:, 0]


def connector(p0, h0: float, p1, h1: float, samples: int = 64) -> np.ndarray:
    """A smooth cubic Bézier from pose (p0, heading h0) to pose (p1, heading h1).

    The inner control points sit along each heading at 40% of the chord: tangent-continuous with
    the lanes on both sides and close to a circular arc for right-angle turns.
    """
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = 0.4 * float(np.hypot(*(p1 - p0)))
    ctrl = np.array(
        [
            p0,
            p0 + d * np.array([np.cos(h0), np.sin(h0)]),
            p1 - d * np.array([np.cos(h1), np.sin(h1)]),
            p1,
        ]
    )
    return de_casteljau(ctrl, np.linspace(0.0, 1.0, samples))


def resample(polyline: np.ndarray, spacing: float = PATH_SPACING) -> np.ndarray:
    """Resample a polyline (n, 2) at uniform arc-length `spacing`.

    Samples sit at exact multiples of `spacing` (the remainder under one spacing at the end is
    dropped), so the arc length of sample `k` is `k * spacing` on every path.
    """
    pts = np.asarray(polyline, float)
    seg = np.hypot(*np.diff(pts, axis=0).T)
    keep = np.concatenate([[True], seg > 1e-9])  # drop repeated points
    pts = pts[keep]
    cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    total = cum[-1]
    n = max(2, int(np.floor(total / spacing)) + 1)
    s = np.arange(n) * spacing
    return np.column_stack([np.interp(s, cum, pts[:, 0]), np.interp(s, cum, pts[:, 1])])


def headings(path: np.ndarray) -> np.ndarray:
    """Tangent heading (rad) at every point of a resampled path."""
    d = np.gradient(path, axis=0)
    return np.arctan2(d[:, 1], d[:, 0])


def curvature(path: np.ndarray) -> np.ndarray:
    """Unsigned curvature (1/m) at every point of a resampled path."""
    h = np.unwrap(headings(path))
    seg = np.maximum(np.hypot(*np.gradient(path, axis=0).T), 1e-9)
    return np.abs(np.gradient(h)) / seg


def arc(center, radius: float, a0: float, a1: float, spacing: float = PATH_SPACING) -> np.ndarray:
    """Points on a circular arc from angle a0 to a1 (counter-clockwise when a1 > a0)."""
    n = max(2, int(abs(a1 - a0) * radius / spacing) + 1)
    a = np.linspace(a0, a1, n)
    return np.column_stack([center[0] + radius * np.cos(a), center[1] + radius * np.sin(a)])
