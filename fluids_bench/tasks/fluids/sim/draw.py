"""Drawing a FLUIDS world: the static layout rasterised once per scale, lights and agents each
frame. The bird's-eye sensor and the renderer for people both draw with it (drawing only reads).

What is drawn, back to front, in `COLOURS`: terrain (green), sidewalks (beige grey),
the drivable area (dark grey) with lane markings (a yellow centre line between opposite
directions, white dashes between lanes of one direction, white stop lines at unsignalised
entries), zebra crosswalks, routes (pink line), light bars (a bar across every signalised stop
line, green / yellow / red, and one at each end of a signalised crosswalk, white / red), cars
(blue, with a dark windscreen at the front), pedestrians (orange) and the ego (magenta).

Speed comes from drawing the static layout once: `static_layer` rasterises it per layout
and pixel scale and caches it; each frame only the dynamic elements are drawn with
`cv2.fillPoly` (one call per colour).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import cv2
import numpy as np
import shapely
from shapely.geometry import LineString
from shapely.ops import substring

from fluids_bench.core.raster import CORNER_SIGNS, SHIFT, boxes_px, line_px, pixel_affine, to_fixed
from fluids_bench.tasks.fluids.sim.layout.compiled import Layout
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.sim.lights import CAUTION, GO, STOP

MAX_MAP_PX = 4096  # largest side of a cached static raster (ego frames upsample beyond it)

COLOURS = {  # RGB
    "terrain": (86, 120, 70),
    "sidewalk": (170, 164, 152),
    "road": (62, 62, 68),
    "crosswalk": (208, 208, 208),
    "centre_line": (232, 192, 40),
    "lane_line": (225, 225, 225),
    "stop_line": (240, 240, 240),
    "car": (60, 130, 245),
    "ego": (235, 45, 220),
    "pedestrian": (255, 150, 30),
    "windscreen": (25, 28, 40),
    "route": (255, 150, 235),
}
# light bar colour by (is_crosswalk, state code)
LIGHT_COLOURS = {
    (False, GO): (40, 225, 70),
    (False, CAUTION): (255, 215, 0),
    (False, STOP): (240, 30, 30),
    (True, GO): (255, 255, 255),
    (True, CAUTION): (255, 215, 0),
    (True, STOP): (240, 30, 30),
}
_LIGHT_PALETTE = [LIGHT_COLOURS[(cw, st)] for cw in (False, True) for st in (GO, CAUTION, STOP)]
MIN_AGENT_PX = 2.5  # agents are drawn at least this many pixels long and wide


# ----------------------------------------------------------------------------- geometry helpers
def _rings(geom) -> list[np.ndarray]:
    """Exterior and interior rings (world coordinates) of every polygon in `geom`."""
    out = []
    for poly in shapely.get_parts(geom):
        if poly.is_empty or poly.geom_type != "Polygon":
            continue
        out.append(np.asarray(poly.exterior.coords))
        out.extend(np.asarray(r.coords) for r in poly.interiors)
    return out


def _quad(centre, along, half_along: float, half_across: float) -> np.ndarray:
    """Corners (4, 2) of a rectangle centred at `centre` with long axis `along` (unit)."""
    c, u = np.asarray(centre, float), np.asarray(along, float)
    n = np.array([-u[1], u[0]])
    return np.array(
        [
            c + half_along * u + half_across * n,
            c + half_along * u - half_across * n,
            c - half_along * u - half_across * n,
            c - half_along * u + half_across * n,
        ]
    )


def _unit(a, b) -> np.ndarray:
    d = np.asarray(b, float) - np.asarray(a, float)
    return d / max(float(np.hypot(*d)), 1e-12)


def _dashes(line: np.ndarray, dash: float = 3.0, gap: float = 3.0) -> list[np.ndarray]:
    ls = LineString(line)
    out, s = [], 1.0
    while s + dash <= ls.length:
        seg = substring(ls, s, s + dash)
        out.append(np.asarray(seg.coords))
        s += dash + gap
    return out


@functools.lru_cache(maxsize=32)
def lane_markings(layout: Layout) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    """World-frame polylines of the layout's markings: (centre lines, lane dashes, stop lines).

    A lane's left edge is a yellow centre line where a lane of the opposite direction runs on
    its other side, a dashed white line where a lane of the same direction does, and unmarked
    otherwise (a kerb). Entry lanes without a light get a white stop line across their end.
    """
    lanes = layout.spec.lanes
    edges = []
    for lane in lanes:
        line = LineString(lane.centerline)
        edges.append(
            (
                line.offset_curve(lane.width / 2),
                line.offset_curve(-lane.width / 2),
                _unit(lane.centerline[0], lane.centerline[-1]),
            )
        )
    # Only a lane with an edge within 0.3 m of lane i's mid-point can decide its marking: an
    # STRtree over every edge finds those (a margin above 0.3 so that the exact test below, in
    # lane order as before, alone decides) instead of n^2 distance calls.
    n = len(edges)
    mids = [left.interpolate(0.5, normalized=True) for left, _, _ in edges]
    tree = shapely.STRtree([e[0] for e in edges] + [e[1] for e in edges])
    near: list[set[int]] = [set() for _ in range(n)]
    if n:
        for i, k in tree.query(mids, predicate="dwithin", distance=0.3 + 1e-6).T.tolist():
            near[i].add(k % n)
    centre, dashes = [], []
    for i, (left, _, u) in enumerate(edges):
        mid = mids[i]
        for j in sorted(near[i]):
            left_j, right_j, u_j = edges[j]
            if i == j:
                continue
            if float(u @ u_j) < -0.5 and left_j.distance(mid) < 0.3:
                if i < j:  # each centre line once
                    centre.append(np.asarray(left.coords))
                break
            if float(u @ u_j) > 0.5 and right_j.distance(mid) < 0.3:
                dashes.extend(_dashes(np.asarray(left.coords)))
                break
    stops = []
    for name in layout.spec.entry_lanes:
        lane = layout.spec.lane(name)
        if lane.light is None:
            p, u = np.asarray(lane.centerline[-1]), _unit(lane.centerline[-2], lane.centerline[-1])
            n = np.array([-u[1], u[0]])
            stops.append(np.array([p + n * lane.width * 0.45, p - n * lane.width * 0.45]))
    return centre, dashes, stops


def _light_quads(layout: Layout, thickness: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bars (Q, 4, 2) showing each light, the light index of each bar, and which are crosswalk
    lights: one across every lane's stop line that a traffic light governs, one at each end of
    every crosswalk that a crosswalk light governs."""
    index = {light.name: i for i, light in enumerate(layout.spec.lights)}
    quads, owner, crosswalk = [], [], []
    for lane in layout.spec.lanes:
        if lane.light is not None:
            p, u = lane.centerline[-1], _unit(lane.centerline[-2], lane.centerline[-1])
            quads.append(_quad(p, u, thickness / 2, lane.width * 0.45))
            owner.append(index[lane.light])
            crosswalk.append(False)
    for cw in layout.spec.crosswalks:
        if cw.light is not None:
            u = _unit(cw.start, cw.end)
            for end in (cw.start, cw.end):
                quads.append(_quad(end, u, thickness / 2, cw.width / 2))
                owner.append(index[cw.light])
                crosswalk.append(True)
    return (
        np.asarray(quads, float).reshape(-1, 4, 2),
        np.asarray(owner, dtype=np.int64),
        np.asarray(crosswalk, dtype=bool),
    )


def _crosswalk_stripes(layout: Layout) -> np.ndarray:
    """Zebra stripes (K, 4, 2): 0.5 m bars every 1 m across each crosswalk, along the traffic."""
    out = []
    for cw in layout.spec.crosswalks:
        u = _unit(cw.start, cw.end)
        length = float(np.hypot(*(np.asarray(cw.end) - cw.start)))
        for s in np.arange(0.5, length - 0.25, 1.0):
            out.append(
                _quad(np.asarray(cw.start) + u * s, -np.array([-u[1], u[0]]), cw.width / 2, 0.25)
            )
    return np.asarray(out, float).reshape(-1, 4, 2)


# ----------------------------------------------------------------------------- static layer
@dataclass(frozen=True, eq=False)
class StaticLayer:
    """A layout rasterised once: `image` (read-only) and the affine `to_pixels` (2×3) from
    world metres to its pixels, plus the light bars (world frame) drawn over it each step."""

    image: np.ndarray
    to_pixels: np.ndarray
    ppm: float  # pixels per metre
    light_quads: np.ndarray  # (Q, 4, 2) world m
    light_of_quad: np.ndarray  # (Q,) index into the layout's lights
    crosswalk_quad: np.ndarray  # (Q,) bool
    # light states → ((colour, bar indices), …): see light_groups
    light_groups: dict = field(default_factory=dict, repr=False)


@functools.lru_cache(maxsize=16)
def static_layer(
    layout: Layout, ppm: float, x0: float, y1: float, width: int, height: int
) -> StaticLayer:
    """Rasterise `layout` at `ppm` pixels per metre into a `height` × `width` image whose
    top-left corner is world (x0, y1). Cached: every sensor on a layout and scale shares one."""
    affine = pixel_affine(ppm, x0, y1)
    img = np.empty((height, width, 3), np.uint8)
    img[:] = COLOURS["terrain"]
    aa = cv2.LINE_AA
    for geom, colour in ((layout.sidewalks, "sidewalk"), (layout.drivable, "road")):
        rings = [to_fixed(affine, r) for r in _rings(geom)]
        if rings:
            cv2.fillPoly(img, rings, COLOURS[colour], aa, SHIFT)
    stripes = _crosswalk_stripes(layout)
    if len(stripes):
        cv2.fillPoly(img, to_fixed(affine, stripes), COLOURS["crosswalk"], aa, SHIFT)
    centre, dashes, stops = lane_markings(layout)
    for lines, colour, metres in (
        (centre, "centre_line", 0.15),
        (dashes, "lane_line", 0.12),
        (stops, "stop_line", 0.4),
    ):
        if lines:
            cv2.polylines(
                img,
                [to_fixed(affine, p) for p in lines],
                False,
                COLOURS[colour],
                line_px(ppm, metres),
                aa,
                SHIFT,
            )
    img.setflags(write=False)
    quads, owner, crosswalk = _light_quads(layout, thickness=max(0.8, 2.0 / ppm))
    return StaticLayer(img, affine, ppm, quads, owner, crosswalk)


def layer_for_bounds(layout: Layout, ppm: float, margin: float = 0.0) -> StaticLayer:
    """The cached raster of the whole layout (plus `margin` m) at `ppm`, capped in size."""
    x0, y0, x1, y1 = layout.bounds
    x0, y0, x1, y1 = x0 - margin, y0 - margin, x1 + margin, y1 + margin
    ppm = min(ppm, MAX_MAP_PX / max(x1 - x0, y1 - y0))
    return static_layer(
        layout, float(ppm), x0, y1, math.ceil((x1 - x0) * ppm), math.ceil((y1 - y0) * ppm)
    )


def square_view(layout: Layout, size: int, margin: float = 0.0) -> tuple[float, float, float]:
    """(ppm, x0, y1) of a `size`-pixel square showing the whole layout (plus `margin` m)."""
    x0, y0, x1, y1 = layout.bounds
    side = max(x1 - x0, y1 - y0) + 2 * margin
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    return size / side, cx - side / 2, cy + side / 2


# ----------------------------------------------------------------------------- dynamic drawing
def draw_route(img, affine, ppm, path: np.ndarray, colour, metres: float = 0.35) -> None:
    """A polyline through `path` (k, 2) world points (every 2 m is plenty)."""
    if len(path) >= 2:
        cv2.polylines(
            img, [to_fixed(affine, path)], False, colour, line_px(ppm, metres), cv2.LINE_AA, SHIFT
        )


def remaining_path(world, agent: int, every: float = 2.0) -> np.ndarray:
    """World points (k, 2) of `agent`'s path from its progress to its end, about `every` m
    apart (the last one within `every` m of the end)."""
    k0 = int(world.s[agent] / PATH_SPACING)
    k1 = int(round(world.path_len[agent] / PATH_SPACING))
    return world.path[agent, k0 : k1 + 1 : max(1, int(every / PATH_SPACING))]


def light_groups(layer: StaticLayer, states: np.ndarray) -> tuple:
    """((colour, bar indices), …) for the lights in `states`, one per colour shown, in
    palette order: what each `fillPoly` call draws. Cached on the layer: the lights cycle
    through a few states, and grouping them costs more numpy calls than drawing."""
    key = (states.dtype.char, states.tobytes())
    groups = layer.light_groups.get(key)
    if groups is None:
        code = layer.crosswalk_quad * 3 + states[layer.light_of_quad]
        colours = np.unique(code).tolist()
        groups = tuple((_LIGHT_PALETTE[c], np.flatnonzero(code == c)) for c in colours)
        layer.light_groups[key] = groups
    return groups


def draw_lights(img, affine, layer: StaticLayer, states: np.ndarray) -> None:
    """Every light bar in the colour of its light's current state."""
    if len(layer.light_quads):
        fill_lights(img, to_fixed(affine, layer.light_quads), layer, states)


def fill_lights(img, quads: np.ndarray, layer: StaticLayer, states: np.ndarray) -> None:
    """`draw_lights` with the bars `layer.light_quads` already in fixed-point pixels."""
    for colour, bars in light_groups(layer, states):
        cv2.fillPoly(img, quads[bars], colour, cv2.LINE_AA, SHIFT)


def agent_boxes(
    affine, ppm: float, world, idx: np.ndarray, grow: float = 0.0, min_px: float = MIN_AGENT_PX
) -> np.ndarray:
    """Fixed-point pixel footprints (len(idx), 4, 2) of `idx`, `grow` m larger all round
    and at least `min_px` pixels a side."""
    st = world.state[idx].T
    floor = min_px / ppm
    return boxes_px(
        affine,
        st[0],
        st[1],
        st[2],
        np.maximum(world.length[idx] + 2 * grow, floor),
        np.maximum(world.width[idx] + 2 * grow, floor),
    )


def visible_agents(world, ego: int = 0) -> np.ndarray:
    """Indices of the agents to draw: the active ones, and the ego always."""
    show = world.active.copy()
    show[ego] = True
    return np.flatnonzero(show)


class AgentPainter:
    """Draws agents at `ppm` pixels per metre, at least `min_px` pixels a side.

    Each world's agent shapes (body and windscreen corners in the agent's frame, as complex
    numbers) are computed once and cached, so a frame costs a fixed handful of numpy calls:
    corner = centre + e^{iθ} · offset, for all agents at once, then one `fillPoly` per colour.
    """

    def __init__(self, ppm: float, min_px: float = MIN_AGENT_PX) -> None:
        self.ppm, self.min_px = float(ppm), float(min_px)
        self._lengths = None  # the world.length array the caches were built from
        self._shapes = np.zeros((0, 8), complex)
        self._groups: dict = {}  # (agents drawn, ego) -> what each fillPoly draws
        self.screens = False

    def _shapes_of(self, world) -> np.ndarray:
        if self._lengths is not world.length:
            floor = self.min_px / self.ppm
            length = np.maximum(world.length, floor)[:, None]
            width = np.maximum(world.width, floor)[:, None]
            body = length * CORNER_SIGNS.real + 1j * (width * CORNER_SIGNS.imag)
            # windscreen: 18% of the length, centred 18% of it ahead of the centre, 80% wide
            fwd = 0.18 * length
            screen = fwd + fwd * CORNER_SIGNS.real + 1j * (0.8 * width * CORNER_SIGNS.imag)
            self._shapes = np.concatenate([body, screen], axis=1)
            self.screens = self.ppm * float(world.scene.car.length) >= 8.0  # a few pixels long
            self._groups.clear()
            self._lengths = world.length
        return self._shapes

    def corners(self, world, idx: np.ndarray) -> np.ndarray:
        """World corners (len(idx), 8, 2) of the bodies (4) and windscreens (4) of `idx`."""
        shapes = self._shapes_of(world)[idx]
        st = world.state[idx]
        z = np.exp(1j * st[:, 2])[:, None] * shapes
        # + x + iy, the first complex of each state row (as floats x + 1j·y would be, but for
        # the sign of a zero part, which no pixel can show)
        z += st.view(np.complex128)[:, :1]
        return z.view(np.float64).reshape(len(idx), 8, 2)

    def draw(self, img, affine, world, idx: np.ndarray, ego: int = 0) -> None:
        """Cars (blue), pedestrians (orange) and the ego (magenta) among `idx`; cars get a dark
        windscreen (it shows the heading) when they are at least 8 pixels long."""
        if len(idx):
            self.fill(img, to_fixed(affine, self.corners(world, idx)), world, idx, ego)

    def fill(self, img, px: np.ndarray, world, idx: np.ndarray, ego: int = 0) -> None:
        """`draw` with the `corners` already in fixed-point pixels `px`."""
        for colour, rows, corners in self._groups_of(world, idx, ego):
            cv2.fillPoly(img, px[rows, corners], colour, cv2.LINE_AA, SHIFT)

    def _groups_of(self, world, idx: np.ndarray, ego: int) -> tuple:
        """((colour, rows of `idx`, corners), …) for each non-empty `fillPoly` call, in
        drawing order. Cached per set of agents drawn and ego: it changes rarely."""
        self._shapes_of(world)  # drops the cache for another world's agents
        key = (idx.tobytes(), ego)
        groups = self._groups.get(key)
        if groups is None:
            is_car, is_ego = world.is_car[idx], idx == ego
            groups = tuple(
                (COLOURS[colour], np.flatnonzero(mask), corners)
                for mask, colour, corners in (
                    (is_car & ~is_ego, "car", slice(0, 4)),
                    (~(is_car | is_ego), "pedestrian", slice(0, 4)),
                    (is_ego, "ego", slice(0, 4)),
                    (is_car & self.screens, "windscreen", slice(4, 8)),
                )
                if mask.any()
            )
            if len(self._groups) >= 256:  # agents come and go: keep the cache small
                self._groups.clear()
            self._groups[key] = groups
        return groups
