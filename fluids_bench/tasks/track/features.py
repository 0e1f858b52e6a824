"""What the learner sees on the track: a bird's-eye RGB image and its HOG descriptor (ch. 6).

As the source: the whole workspace drawn from above at one pixel per unit (500×500 by
default), downsampled with two Gaussian-pyramid steps (`cv2.pyrDown`) to 125×125 RGB, then
described with OpenCV's Histogram of Oriented Gradients (`cv2.HOGDescriptor`).

HOG parameters (ours; the source reports only the resulting 27,926 dimensions): the window is
the whole 125×125 image, 5×5-pixel cells, blocks of 2×2 cells moved by one cell, 9 unsigned
orientation bins, OpenCV's defaults otherwise (Gaussian block weighting, L2-Hys block norm).
That is 24 × 24 blocks × 4 cells × 9 bins = `HOG_DIM` = 20,736 dimensions.

OpenCV 5 moved `HOGDescriptor` out of the main `opencv-python-headless` wheel; it is in
`opencv-contrib-python-headless` (the same OpenCV with the extra modules), which the suite
depends on instead.

The road and the grass never change within an episode, so they are drawn once per track and
only the car is drawn per frame.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from fluids_bench.core.raster import ONE, SHIFT, boxes_px, line_px, pixel_affine, to_fixed
from fluids_bench.tasks.track.sim import Track

IMAGE_SIZE = 125  # side of the observed image (pixels)
PYRAMID_STEPS = 2  # each cv2.pyrDown halves the side: 500 -> 250 -> 125
HOG_WIN = (IMAGE_SIZE, IMAGE_SIZE)
HOG_BLOCK = (10, 10)
HOG_STRIDE = (5, 5)
HOG_CELL = (5, 5)
HOG_BINS = 9
HOG_DIM = 24 * 24 * 4 * HOG_BINS  # 20,736

GRASS = (46, 125, 50)
ROAD = (120, 120, 120)
CENTRE_LINE = (235, 235, 235)
CAR = (220, 30, 30)
CAR_LENGTH = 20.0  # units
CAR_WIDTH = 10.0
NOSE_RADIUS = 2.5  # units
# input pixels one output pixel of the pyramid depends on, each side: 2 + 2·2 for two steps
INFLUENCE = 6
PATCH_MARGIN = 20  # pixels drawn around the car's box: > INFLUENCE + anti-aliasing + rounding


def hog_descriptor() -> cv2.HOGDescriptor:
    """OpenCV's HOG with the parameters above (a clear error if this OpenCV lacks it)."""
    if not hasattr(cv2, "HOGDescriptor"):
        raise ImportError(
            "obs_type 'hog' needs cv2.HOGDescriptor, which OpenCV 5 ships only in the contrib "
            "wheel: pip uninstall opencv-python-headless && "
            "pip install opencv-contrib-python-headless"
        )
    return cv2.HOGDescriptor(HOG_WIN, HOG_BLOCK, HOG_STRIDE, HOG_CELL, HOG_BINS)


class BirdsEye:
    """Draws the track (once) and the car (per frame) at `scale` pixels per unit, then
    downsamples by Gaussian pyramid steps: the source's image pipeline."""

    def __init__(self, track: Track, workspace: float, size: int = IMAGE_SIZE) -> None:
        self.full = size << PYRAMID_STEPS  # drawing resolution before the pyramid
        self.ppu = self.full / workspace
        self.affine = pixel_affine(self.ppu, 0.0, workspace)
        self.background = np.empty((self.full, self.full, 3), np.uint8)
        self.background[:] = GRASS
        ring = to_fixed(self.affine, np.vstack([track.vertices, track.vertices[:1]]))
        cv2.polylines(
            self.background, [ring], True, ROAD, line_px(self.ppu, 2 * track.half_width),
            cv2.LINE_AA, SHIFT,
        )  # fmt: skip
        cv2.polylines(self.background, [ring], True, CENTRE_LINE, 1, cv2.LINE_AA, SHIFT)
        self.small_background = self.background
        for _ in range(PYRAMID_STEPS):
            self.small_background = cv2.pyrDown(self.small_background)

    def _car_shapes(self, x: float, y: float, heading: float) -> tuple[np.ndarray, np.ndarray]:
        """Fixed-point pixel corners of the car's body (1, 4, 2) and its nose centre (2,)."""
        box = boxes_px(
            self.affine, np.array([x]), np.array([y]), np.array([heading]),
            np.array([CAR_LENGTH]), np.array([CAR_WIDTH]),
        )  # fmt: skip
        tip = 0.35 * CAR_LENGTH
        nose = to_fixed(
            self.affine, np.array([[x + tip * math.cos(heading), y + tip * math.sin(heading)]])
        )[0]
        return box, nose

    def _draw_car(self, image: np.ndarray, box: np.ndarray, nose: np.ndarray) -> None:
        cv2.fillPoly(image, box, CAR, cv2.LINE_AA, SHIFT)
        # a light nose marks the heading
        radius = int(round(NOSE_RADIUS * self.ppu * ONE))
        cv2.circle(image, (int(nose[0]), int(nose[1])), radius, CENTRE_LINE, -1, cv2.LINE_AA, SHIFT)

    def full_frame(self, x: float, y: float, heading: float) -> np.ndarray:
        """The frame at drawing resolution (a new array)."""
        image = self.background.copy()
        self._draw_car(image, *self._car_shapes(x, y, heading))
        return image

    def frame_reference(self, x: float, y: float, heading: float) -> np.ndarray:
        """The observed frame computed the plain way: draw everything, downsample everything."""
        image = self.full_frame(x, y, heading)
        for _ in range(PYRAMID_STEPS):
            image = cv2.pyrDown(image)
        return image

    def frame(self, x: float, y: float, heading: float) -> np.ndarray:
        """The observed `size`×`size` RGB frame (a new array), bit-identical to
        `frame_reference` but ~10× cheaper.

        The pyramid of the background is computed once. Per frame only a patch around the car
        is drawn and downsampled: an output pixel of two `pyrDown` steps depends on input
        rows and columns within ±6 of 4× its own, so with the patch's corners on multiples of 4
        and a margin beyond the car, the patch's inner output pixels are exactly the full
        image's, and the pixels outside them do not see the car. A patch cut at the image's
        edge reflects there exactly as the full image does.
        """
        box, nose = self._car_shapes(x, y, heading)
        out = self.small_background.copy()
        pixels = box[0] >> SHIFT
        lo = pixels.min(axis=0) - PATCH_MARGIN
        hi = pixels.max(axis=0) + PATCH_MARGIN
        step = 1 << PYRAMID_STEPS
        c0, r0 = (max(0, v // step * step) for v in lo)
        c1, r1 = (min(self.full, -(-v // step) * step) for v in hi)
        if c1 - c0 < 2 * INFLUENCE or r1 - r0 < 2 * INFLUENCE:
            return self.frame_reference(x, y, heading)  # car (almost) outside the image
        patch = self.background[r0:r1, c0:c1].copy()
        offset = np.array([c0, r0]) << SHIFT
        self._draw_car(patch, box - offset, nose - offset)
        for _ in range(PYRAMID_STEPS):
            patch = cv2.pyrDown(patch)
        # exact outputs: at least INFLUENCE input pixels inside every cut edge
        top = 0 if r0 == 0 else -(-(r0 + INFLUENCE) // step) - r0 // step
        left = 0 if c0 == 0 else -(-(c0 + INFLUENCE) // step) - c0 // step
        bottom = (
            patch.shape[0] if r1 == self.full else (r1 - 1 - INFLUENCE) // step - r0 // step + 1
        )
        right = patch.shape[1] if c1 == self.full else (c1 - 1 - INFLUENCE) // step - c0 // step + 1
        out[r0 // step + top : r0 // step + bottom, c0 // step + left : c0 // step + right] = patch[
            top:bottom, left:right
        ]
        return out
