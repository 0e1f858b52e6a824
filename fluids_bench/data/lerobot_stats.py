"""`meta/stats.json` of an exported LeRobotDataset: per-feature statistics for normalisation.

LeRobot (v3.0 datasets) reads `meta/stats.json` as `{feature: {"min", "max", "mean", "std",
"count"}}`, each a (nested) list of numbers that it turns into arrays; its policies normalise
their inputs and outputs with them. The layout follows LeRobot's own statistics:

- a non-image feature of shape `S` (one row per frame): statistics over the frames, each of
  shape `S` (`[1]` for a scalar); the standard deviation is the population one (`ddof=0`);
- an image (a video feature, `(H, W, 3)` `uint8`): per channel over every pixel of every frame,
  with pixels scaled to `[0, 1]` (what LeRobot's loader returns), each of shape `(3, 1, 1)`;
- `count`: `[frames]`, the number of frames the statistics cover.

Booleans count as 0 and 1. The image statistics are accumulated episode by episode (the frames
are not kept), in float64.
"""

from __future__ import annotations

from typing import Any

import numpy as np

STATS_PATH = "meta/stats.json"


def array_stats(values: np.ndarray) -> dict[str, list[Any]]:
    """The statistics of one non-image feature from its rows `(frames, *shape)`; a 1-D column
    (a scalar feature) gives statistics of shape `[1]`."""
    x = np.asarray(values, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    if x.shape[0] == 0:
        raise ValueError("LeRobot stats: a feature has no frame")
    return {
        "min": x.min(axis=0).tolist(),
        "max": x.max(axis=0).tolist(),
        "mean": x.mean(axis=0).tolist(),
        "std": x.std(axis=0).tolist(),
        "count": [int(x.shape[0])],
    }


class ImageStats:
    """Per-channel statistics of `(n, H, W, C)` `uint8` frames, added episode by episode."""

    def __init__(self) -> None:
        self.frames = 0
        self.pixels = 0
        self.total: np.ndarray | None = None
        self.squares: np.ndarray | None = None
        self.low: np.ndarray | None = None
        self.high: np.ndarray | None = None

    def add(self, frames: np.ndarray) -> None:
        x = np.asarray(frames)
        if x.ndim != 4 or x.shape[0] == 0:
            raise ValueError(f"LeRobot stats: frames of shape {x.shape}; allowed: (n, H, W, C)")
        pixels = x.reshape(-1, x.shape[-1]).astype(np.float64) / 255.0
        total, squares = pixels.sum(axis=0), np.square(pixels).sum(axis=0)
        low, high = pixels.min(axis=0), pixels.max(axis=0)
        if self.total is None:
            self.total, self.squares, self.low, self.high = total, squares, low, high
        else:
            self.total, self.squares = self.total + total, self.squares + squares
            self.low, self.high = np.minimum(self.low, low), np.maximum(self.high, high)
        self.frames += x.shape[0]
        self.pixels += pixels.shape[0]

    def result(self) -> dict[str, list[Any]]:
        if self.total is None:
            raise ValueError("LeRobot stats: an image feature has no frame")
        mean = self.total / self.pixels
        std = np.sqrt(np.maximum(self.squares / self.pixels - np.square(mean), 0.0))

        def channels(v: np.ndarray) -> list[Any]:
            return v.reshape(-1, 1, 1).tolist()

        return {
            "min": channels(self.low),
            "max": channels(self.high),
            "mean": channels(mean),
            "std": channels(std),
            "count": [self.frames],
        }
