"""The bird's-eye view of ch. 7: a top-down RGB image (uint8, H × W × 3) of the scene around the
ego (or the whole layout), drawn by `fluids_bench.tasks.fluids.sim.draw`.

Each step only the dynamic elements are drawn over a copy of the cached static raster (global
frame) or over a `cv2.warpAffine` crop of it centred on the ego (ego frames, optionally
rotated).

Noise: with variance λ_p > 0, zero-mean Gaussian noise of variance λ_p is added to every pixel
value, rounded to the nearest integer and clipped to [0, 255] (the bound).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from fluids_bench.core.raster import SHIFT, line_px, to_fixed
from fluids_bench.tasks.fluids.sim.draw import (
    COLOURS,
    AgentPainter,
    fill_lights,
    layer_for_bounds,
    remaining_path,
    square_view,
    static_layer,
    visible_agents,
)
from fluids_bench.tasks.fluids.sim.layout.compiled import Layout

FRAMES = ("ego", "ego_rotated", "global")


def add_pixel_noise(img: np.ndarray, std: float, rng: np.random.Generator) -> np.ndarray:
    """`img` plus zero-mean Gaussian noise of standard deviation `std` (drawn from `rng`),
    rounded to the nearest integer and saturated to [0, 255] by OpenCV."""
    noise = rng.standard_normal(img.shape, dtype=np.float32)
    noise *= std
    return cv2.add(img, noise, dtype=cv2.CV_8U)


# ----------------------------------------------------------------------------- the sensor
class BirdsEyeSensor:
    """Top-down RGB image of `size` × `size` pixels.

    `frame="ego"`: a north-up square of side `fov` metres centred on the ego;
    `"ego_rotated"`: the same square turned so that the ego faces up; `"global"`: the whole
    layout (its bounds' enclosing square; `fov` unused). `noise_var` is λ_p.
    """

    def __init__(
        self,
        layout: Layout,
        size: int = 84,
        fov: float = 40.0,
        frame: str = "ego",
        noise_var: float = 0.0,
    ) -> None:
        if frame not in FRAMES:
            raise ValueError(f"BirdsEyeSensor: field 'frame' is {frame!r}; allowed: {list(FRAMES)}")
        self.size, self.fov, self.frame = int(size), float(fov), frame
        self.shape = (self.size, self.size, 3)
        self.noise_std = math.sqrt(noise_var)
        if frame == "global":
            self.ppm, x0, y1 = square_view(layout, self.size)
            self.layer = static_layer(layout, self.ppm, x0, y1, self.size, self.size)
        else:  # a raster with room around the layout for views centred near its edges
            self.ppm = self.size / self.fov
            self.layer = layer_for_bounds(layout, self.ppm, margin=0.75 * self.fov + 1.0)
        self._centre = self.size / 2 - 0.5  # pixel coordinate of the image centre
        self._map_inv = np.array([1.0, -1.0]) / self.layer.ppm  # diagonal of the raster's L⁻¹
        self._border = tuple(int(c) for c in COLOURS["terrain"])
        # north-up at the raster's own scale: the view is a crop, shifted by whole pixels
        self._crop = frame == "ego" and self.layer.ppm == self.ppm
        self._shift = self.layer.to_pixels[:, 2].tolist()  # the raster's (u, v) of world (0, 0)
        self._route_px = line_px(self.ppm, 0.35)
        self.painter = AgentPainter(self.ppm)

    def view(self, world, ego: int = 0) -> np.ndarray:
        """The world → output-pixel affine (2×3) for the current state. In the `"ego"` frame
        the view is a crop of the static raster moved by whole pixels, so the ego sits within
        half a pixel of the image centre (and the background needs no resampling)."""
        return self._view(world, ego)[0]

    def _view(self, world, ego: int) -> tuple[np.ndarray, tuple[int, int] | None]:
        """`view` and, for a crop, the raster (row, column) of its top-left pixel."""
        if self.frame == "global":
            return self.layer.to_pixels, None
        ex, ey, th, _ = world.state[ego].tolist()
        p, c = self.ppm, self._centre
        if self._crop:
            u, v = self._shift
            col, row = round(u + p * ex - c), round(v - p * ey - c)
            return np.array([[p, 0.0, u - col], [0.0, -p, v - row]]), (row, col)
        if self.frame == "ego":
            lin = np.array([[p, 0.0], [0.0, -p]])
        else:  # rotate by π/2 − θ, so that the heading points up the image
            phi = math.pi / 2 - th
            cs, sn = math.cos(phi), math.sin(phi)
            lin = np.array([[p * cs, -p * sn], [-p * sn, -p * cs]])
        return np.column_stack([lin, [c, c] - lin @ (ex, ey)]), None

    def _background(self, affine: np.ndarray, corner: tuple[int, int] | None) -> np.ndarray:
        """The static raster seen through `affine`: a copy of it (global), a crop (ego frame
        inside the raster), else a resampling."""
        image = self.layer.image
        if self.frame == "global":
            return image.copy()
        if corner is not None:
            row, col = corner
            if 0 <= row <= image.shape[0] - self.size and 0 <= col <= image.shape[1] - self.size:
                return image[row : row + self.size, col : col + self.size].copy()
        # map pixel = L · world + l, out = A · world + a  ⇒  out = A L⁻¹ · map + a − A L⁻¹ l
        lin = affine[:, :2] * self._map_inv
        warp = np.column_stack([lin, affine[:, 2] - lin @ self.layer.to_pixels[:, 2]])
        return cv2.warpAffine(
            image,
            warp,
            (self.size, self.size),
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=self._border,
        )

    def render(self, world, ego: int = 0) -> np.ndarray:
        """The noiseless image: the static raster, then the ego's route, the light bars and the
        agents. All their points go through the view in one `to_fixed` call (each point's
        pixel does not depend on what else is in the call)."""
        affine, corner = self._view(world, ego)
        img = self._background(affine, corner)
        path = remaining_path(world, ego)
        quads = self.layer.light_quads
        idx = visible_agents(world, ego)
        px = to_fixed(
            affine,
            np.concatenate(
                [path, quads.reshape(-1, 2), self.painter.corners(world, idx).reshape(-1, 2)]
            ),
        )
        k, q = len(path), len(path) + 4 * len(quads)
        if k >= 2:
            cv2.polylines(
                img, [px[:k]], False, COLOURS["route"], self._route_px, cv2.LINE_AA, SHIFT
            )
        if len(quads):
            fill_lights(img, px[k:q].reshape(-1, 4, 2), self.layer, world.light_state)
        self.painter.fill(img, px[q:].reshape(-1, 8, 2), world, idx, ego)
        return img

    def observe(self, world, rng: np.random.Generator, ego: int = 0) -> np.ndarray:
        img = self.render(world, ego)
        if self.noise_std > 0:
            img = add_pixel_noise(img, self.noise_std, rng)
        return img
