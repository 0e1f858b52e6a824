"""Pictures of the simulator for people: a global top-down view of a world or of a bare layout.

Drawing only reads the world. It reuses the cached static raster and the drawing of lights and
agents of `fluids_bench.tasks.fluids.sim.draw` (as the bird's-eye sensor does), and adds what a person
watching needs: every car's remaining route (thin), the ego's (thick pink), this step's
collisions (red outlines and a banner), the time and step, and a legend.

The `"human"` render mode shows frames in a pygame window; pygame is the optional `human`
extra (`pip install "fluids-bench[human]"`).
"""

from __future__ import annotations

import os

import cv2
import numpy as np

from fluids_bench.core.raster import SHIFT, to_fixed
from fluids_bench.tasks.fluids.sim.draw import (
    COLOURS,
    LIGHT_COLOURS,
    AgentPainter,
    agent_boxes,
    draw_lights,
    draw_route,
    remaining_path,
    square_view,
    static_layer,
    visible_agents,
)
from fluids_bench.tasks.fluids.sim.layout.compiled import CAR, Layout
from fluids_bench.tasks.fluids.sim.lights import LightProgram

RENDER_SIZE = 640  # pixels, a multiple of 16 (video codecs want it)
COLLISION = (255, 30, 30)
OTHER_ROUTE = (150, 185, 250)
WALK = (250, 190, 120)
MIN_PX = 5.0  # agents drawn at least this many pixels a side (pedestrians stay visible)
_FONT = cv2.FONT_HERSHEY_SIMPLEX
_AA = cv2.LINE_AA
LAYOUT_LEGEND = (("car route", COLOURS["route"]), ("walk", WALK))
LEGEND = (
    ("ego", COLOURS["ego"]),
    ("car", COLOURS["car"]),
    ("pedestrian", COLOURS["pedestrian"]),
    ("ego route", COLOURS["route"]),
    ("collision", COLLISION),
)
LIGHT_LEGEND = (
    ("light green", LIGHT_COLOURS[(False, 0)]),
    ("light yellow", LIGHT_COLOURS[(False, 1)]),
    ("light red", LIGHT_COLOURS[(False, 2)]),
    ("crosswalk open", LIGHT_COLOURS[(True, 0)]),
)


def _shade(img, x0: int, y0: int, x1: int, y1: int) -> None:
    """Darken a box of `img` (clipped to it), as a backdrop for text."""
    h, w = img.shape[:2]
    roi = img[max(0, y0) : min(h, y1), max(0, x0) : min(w, x1)]
    roi[:] = (roi * 0.3).astype(np.uint8)


def _text(img, text: str, org, scale: float, colour=(255, 255, 255)) -> None:
    """One line of text (baseline-left at `org`) on a dark backdrop, readable anywhere."""
    (tw, th), base = cv2.getTextSize(text, _FONT, scale, 1)
    x, y = org
    _shade(img, x - 4, y - th - 4, x + tw + 4, y + base + 2)
    cv2.putText(img, text, org, _FONT, scale, colour, 1, _AA)


def draw_legend(img, items, corner: str, scale: float) -> None:
    """A boxed legend of coloured swatches in the `corner` ("bl" or "br") of `img`."""
    h, w = img.shape[:2]
    line = int(22 * scale / 0.5)
    sw = int(12 * scale / 0.5)
    width = max(cv2.getTextSize(t, _FONT, scale, 1)[0][0] for t, _ in items) + sw + 20
    height = line * len(items) + 8
    x0 = 8 if corner == "bl" else w - width - 8
    y0 = h - height - 8
    _shade(img, x0, y0, x0 + width, y0 + height)
    for i, (label, colour) in enumerate(items):
        y = y0 + 6 + i * line
        cv2.rectangle(img, (x0 + 6, y + 2), (x0 + 6 + sw, y + 2 + sw), colour, -1)
        cv2.putText(img, label, (x0 + sw + 12, y + sw), _FONT, scale, (255, 255, 255), 1, _AA)


class Renderer:
    """Global RGB view of worlds on `layout`: `size` × `size` pixels, the whole layout."""

    def __init__(self, layout: Layout, size: int = RENDER_SIZE, legend: bool = True) -> None:
        self.layout = layout
        self.size = int(size)
        self.ppm, x0, y1 = square_view(layout, self.size, margin=1.0)
        self.layer = static_layer(layout, self.ppm, x0, y1, self.size, self.size)
        self.affine = self.layer.to_pixels
        self.painter = AgentPainter(self.ppm, MIN_PX)
        self.legend = legend
        self.scale = 0.5 * self.size / RENDER_SIZE
        self.base = self._base(LEGEND if legend else ())

    def _base(self, legend) -> np.ndarray:
        """The static raster with the legends burnt in (read-only)."""
        base = self.layer.image.copy()
        if legend:
            draw_legend(base, legend, "bl", self.scale)
        if legend and len(self.layout.spec.lights):
            draw_legend(base, LIGHT_LEGEND, "br", self.scale)
        base.setflags(write=False)
        return base

    def _routes(self, img, paths, colour, thickness: int) -> None:
        lines = [to_fixed(self.affine, p) for p in paths if len(p) >= 2]
        if lines:
            cv2.polylines(img, lines, False, colour, thickness, _AA, SHIFT)

    def render(self, world, ego: int = 0) -> np.ndarray:
        """The frame (size, size, 3) uint8 RGB of `world`'s current state."""
        img = self.base.copy()
        a, ppm = self.affine, self.ppm
        idx = visible_agents(world, ego)
        others = [i for i in idx if i != ego and world.kind[i] == CAR]
        self._routes(img, [remaining_path(world, i) for i in others], OTHER_ROUTE, 1)
        draw_route(img, a, ppm, remaining_path(world, ego), COLOURS["route"], 0.6)
        draw_lights(img, a, self.layer, world.light_state)
        self.painter.draw(img, a, world, idx, ego)
        events = [e for e in world.log if e.step == world.steps]
        hit = sorted({i for e in events for i in (e.a, e.b) if i >= 0})
        if hit:
            boxes = agent_boxes(a, ppm, world, np.asarray(hit), grow=0.5)
            cv2.polylines(img, boxes, True, COLLISION, max(2, self.size // 240), _AA, SHIFT)
        s = self.scale
        _text(img, f"t = {world.time:.1f} s, step {world.steps}", (10, int(24 * s / 0.5)), s)
        if events:
            kinds = ", ".join(sorted({e.kind for e in events}))
            _text(img, f"COLLISION: {kinds}", (10, int(52 * s / 0.5)), s, COLLISION)
        return img

    def render_layout(self, t: float = 0.0) -> np.ndarray:
        """A preview of the bare layout: every car route and walk, the lights as at time `t`."""
        img = self._base(LAYOUT_LEGEND if self.legend else ()).copy()
        routes = self.layout.routes
        lengths = np.rint(routes.length / 0.5).astype(int)
        step = 4
        paths = [routes.path[r, : lengths[r] + 1 : step] for r in range(len(routes.names))]
        cars = [p for p, k in zip(paths, routes.kind, strict=True) if k == CAR]
        walks = [p for p, k in zip(paths, routes.kind, strict=True) if k != CAR]
        self._routes(img, walks, WALK, 1)
        self._routes(img, cars, COLOURS["route"], max(1, self.size // 400))
        lights = LightProgram(self.layout.spec.lights)
        draw_lights(img, self.affine, self.layer, lights.states(t))
        spec = self.layout.spec
        title = (
            f"{spec.name}: {len(spec.lanes)} lanes, {len(cars)} car routes, "
            f"{len(walks)} walks, {len(spec.lights)} lights"
        )
        _text(img, title, (10, int(24 * self.scale / 0.5)), self.scale)
        return img


RAY_COLOURS = {
    0: (235, 235, 235),
    1: (255, 40, 40),
    2: (255, 150, 30),
    3: (60, 220, 255),
}  # by label
RAY_LEGEND = (
    ("ray: nothing", RAY_COLOURS[0]),
    ("ray: car", RAY_COLOURS[1]),
    ("ray: pedestrian", RAY_COLOURS[2]),
    ("ray: road edge", RAY_COLOURS[3]),
)


def draw_rays(img, affine, world, offsets: np.ndarray, reading: np.ndarray, ego: int = 0) -> None:
    """Quasi-LIDAR rays over a frame, like ch. 7's Fig. 7.5: from the ego's centre to each
    ray's reading distance, coloured by what it hit (`RAY_COLOURS`: nothing white,
    car red, pedestrian orange, road edge cyan). `reading` is a (m, 4) observation."""
    x, y, th, _ = world.state[ego]
    ang = th + offsets
    ends = np.column_stack([x + reading[:, 0] * np.cos(ang), y + reading[:, 0] * np.sin(ang)])
    start = to_fixed(affine, np.array([[x, y]]))[0]
    tips = to_fixed(affine, ends)
    labels = reading[:, 1].astype(int)
    for label, colour in RAY_COLOURS.items():
        lines = [np.array([start, tip]) for tip in tips[labels == label]]
        if lines:
            cv2.polylines(img, lines, False, colour, 2 if label in (1, 2) else 1, _AA, SHIFT)
    for tip, label in zip(tips, labels, strict=True):
        if label:
            radius = (3 if label in (1, 2) else 2) << SHIFT
            cv2.circle(img, tuple(int(v) for v in tip), radius, RAY_COLOURS[label], -1, _AA, SHIFT)


def require_pygame():
    """Import pygame, or fail naming the extra that provides it."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    try:
        import pygame
    except ImportError as exc:
        raise ImportError(
            'render_mode="human" needs pygame, an optional extra: pip install "fluids-bench[human]"'
        ) from exc
    return pygame


class HumanWindow:
    """A pygame window showing RGB frames at most `fps` per second."""

    def __init__(self, title: str = "FLUIDS", fps: int = 10) -> None:
        self.pygame = require_pygame()
        self.title, self.fps = title, fps
        self.screen = None
        self.clock = None

    def show(self, frame: np.ndarray) -> None:
        pg = self.pygame
        if self.screen is None:
            pg.display.init()
            pg.display.set_caption(self.title)
            self.screen = pg.display.set_mode((frame.shape[1], frame.shape[0]))
            self.clock = pg.time.Clock()
        pg.event.pump()
        self.screen.blit(
            pg.surfarray.make_surface(np.ascontiguousarray(frame.swapaxes(0, 1))), (0, 0)
        )
        pg.display.flip()
        self.clock.tick(self.fps)

    def close(self) -> None:
        if self.screen is not None:
            self.pygame.display.quit()
            self.screen = None
