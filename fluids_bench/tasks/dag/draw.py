"""DAG-v0's picture: the graph from the root down, edges labelled with their rewards, the
robot's node filled (the edge it came by drawn thick). OpenCV only, no window."""

from __future__ import annotations

import cv2
import numpy as np

from fluids_bench.tasks.dag.model import DEPTH, EDGE_REWARDS, L, R

SIZE = 320  # px, square
MARGIN = 40  # px around the graph
RADIUS = 14  # px per node
BACKGROUND, INK, ROBOT, TAKEN = (255, 255, 255), (60, 60, 60), (220, 80, 40), (40, 120, 220)


def node_centre(level: int, index: int) -> tuple[int, int]:
    """Pixel (x, y) of node `(level, index)`: levels top to bottom, right moves to the right."""
    step = (SIZE - 2 * MARGIN) / DEPTH
    x = SIZE / 2 + (index - level / 2) * step
    return int(round(x)), int(round(MARGIN + level * step))


def draw_dag(level: int, index: int, last_edge: tuple[int, int, int] | None = None) -> np.ndarray:
    """RGB image (SIZE, SIZE, 3) with the robot at `(level, index)`; `last_edge` =
    (level, index, move) of the edge just taken, or None at the root."""
    image = np.full((SIZE, SIZE, 3), BACKGROUND, dtype=np.uint8)
    for lv in range(DEPTH):
        for ix in range(lv + 1):
            for move in (L, R):
                a, b = node_centre(lv, ix), node_centre(lv + 1, ix + move)
                taken = last_edge == (lv, ix, move)
                cv2.line(image, a, b, TAKEN if taken else INK, 4 if taken else 1, cv2.LINE_AA)
                # a third of the way down, beside the edge: shared children keep labels apart
                mid = (int(a[0] + (b[0] - a[0]) / 3) + (-20 if move == L else 8),
                       int(a[1] + (b[1] - a[1]) / 3) + 4)  # fmt: skip
                reward = f"{EDGE_REWARDS[lv][ix][move]:g}"
                cv2.putText(image, reward, mid, cv2.FONT_HERSHEY_SIMPLEX, 0.45, INK, 1, cv2.LINE_AA)
    for lv in range(DEPTH + 1):
        for ix in range(lv + 1):
            here = (lv, ix) == (level, index)
            centre = node_centre(lv, ix)
            cv2.circle(image, centre, RADIUS, ROBOT if here else BACKGROUND, -1, cv2.LINE_AA)
            cv2.circle(image, centre, RADIUS, INK, 1, cv2.LINE_AA)
    return image
