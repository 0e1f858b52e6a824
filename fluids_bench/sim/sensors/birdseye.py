"""The bird's-eye view of ch. 7: a top-down RGB image (uint8, H × W × 3) of the scene.

What is drawn, back to front, in :data:`COLOURS`: terrain (green), sidewalks (beige grey),
the drivable area (dark grey) with lane markings (a yellow centre line between opposite
directions, white dashes between lanes of one direction, white stop lines at unsignalised
entries), zebra crosswalks, the ego's remaining route (pink line), light bars (a bar across
every signalised stop line, green / yellow / red, and one at each end of a signalised crosswalk,
white / red), cars (blue, with a dark windscreen at the front), pedestrians (orange) and the ego
(magenta).

Speed comes from drawing the static layout once: :func:`static_layer` rasterises it per layout
and pixel scale and caches it. Each step only the dynamic elements are drawn with
``cv2.fillPoly`` (one call per colour), over a copy of the cached raster (global frame) or over
a ``cv2.warpAffine`` crop of it centred on the ego (ego frames, optionally rotated).

Pixel convention: pixel ``(row, col)`` is centred at ``u = col``, ``v = row`` in the affine maps
used here, with ``u`` to the east and ``v`` to the south (world ``y`` points up the image).

Noise: with variance λ_p > 0, zero-mean Gaussian noise of variance λ_p is added to every pixel
value, rounded to the nearest integer and clipped to [0, 255] (the bound).
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

from fluids_bench.sim.layout.compiled import Layout
from fluids_bench.sim.layout.geometry import PATH_SPACING
from fluids_bench.sim.lights import CAUTION, GO, STOP

FRAMES = ("ego", "ego_rotated", "global")
SHIFT = 4  # fractional bits of the fixed-point pixel coordinates passed to OpenCV
ONE = 1 << SHIFT
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
def to_fixed(affine: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """World points (..., 2) through the 2×3 ``affine`` to OpenCV fixed-point pixels (int32)."""
    flat = cv2.transform(
        np.ascontiguousarray(pts, dtype=np.float64).reshape(-1, 1, 2), affine * ONE
    )
    return np.rint(flat).astype(np.int32).reshape(pts.shape)


def _rings(geom) -> list[np.ndarray]:
    """Exterior and interior rings (world coordinates) of every polygon in ``geom``."""
    out = []
    for poly in shapely.get_parts(geom):
        if poly.is_empty or poly.geom_type != "Polygon":
            continue
        out.append(np.asarray(poly.exterior.coords))
        out.extend(np.asarray(r.coords) for r in poly.interiors)
    return out


def _quad(centre, along, half_along: float, half_across: float) -> np.ndarray:
    """Corners (4, 2) of a rectangle centred at ``centre`` with long axis ``along`` (unit)."""
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
    centre, dashes = [], []
    for i, (left, _, u) in enumerate(edges):
        mid = left.interpolate(0.5, normalized=True)
        for j, (left_j, right_j, u_j) in enumerate(edges):
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
    """A layout rasterised once: ``image`` (read-only) and the affine ``to_pixels`` (2×3) from
    world metres to its pixels, plus the light bars (world frame) drawn over it each step."""

    image: np.ndarray
    to_pixels: np.ndarray
    ppm: float  # pixels per metre
    light_quads: np.ndarray  # (Q, 4, 2) world m
    light_of_quad: np.ndarray  # (Q,) index into the layout's lights
    crosswalk_quad: np.ndarray  # (Q,) bool
    # light states → ((colour, bar indices), …): see light_groups
    light_groups: dict = field(default_factory=dict, repr=False)


def pixel_affine(ppm: float, x0: float, y1: float) -> np.ndarray:
    """World → pixel map of a raster whose top-left corner is world (x0, y1)."""
    return np.array([[ppm, 0.0, -x0 * ppm - 0.5], [0.0, -ppm, y1 * ppm - 0.5]])


def line_px(ppm: float, metres: float) -> int:
    """A line thickness in whole pixels, at least 1."""
    return max(1, int(round(metres * ppm)))


@functools.lru_cache(maxsize=16)
def static_layer(
    layout: Layout, ppm: float, x0: float, y1: float, width: int, height: int
) -> StaticLayer:
    """Rasterise ``layout`` at ``ppm`` pixels per metre into a ``height`` × ``width`` image whose
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
    """The cached raster of the whole layout (plus ``margin`` m) at ``ppm``, capped in size."""
    x0, y0, x1, y1 = layout.bounds
    x0, y0, x1, y1 = x0 - margin, y0 - margin, x1 + margin, y1 + margin
    ppm = min(ppm, MAX_MAP_PX / max(x1 - x0, y1 - y0))
    return static_layer(
        layout, float(ppm), x0, y1, math.ceil((x1 - x0) * ppm), math.ceil((y1 - y0) * ppm)
    )


def square_view(layout: Layout, size: int, margin: float = 0.0) -> tuple[float, float, float]:
    """(ppm, x0, y1) of a ``size``-pixel square showing the whole layout (plus ``margin`` m)."""
    x0, y0, x1, y1 = layout.bounds
    side = max(x1 - x0, y1 - y0) + 2 * margin
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    return size / side, cx - side / 2, cy + side / 2


# ----------------------------------------------------------------------------- dynamic drawing
_CORNER_SIGNS = np.array([1 + 1j, 1 - 1j, -1 - 1j, -1 + 1j]) / 2  # (±length, ±width) halves


def boxes_px(affine, x, y, th, length, width) -> np.ndarray:
    """Fixed-point pixel corners (n, 4, 2) of rectangles centred at world (x, y), ``length`` m
    along heading ``th``, ``width`` m across (all (n,) arrays). Complex arithmetic: a corner is
    ``x + iy + e^{iθ}(±l ± iw)/2``, few numpy calls for any n."""
    local = length[:, None] * _CORNER_SIGNS.real + 1j * (width[:, None] * _CORNER_SIGNS.imag)
    z = np.exp(1j * th)[:, None] * local
    z += (x + 1j * y)[:, None]
    return to_fixed(affine, z.view(np.float64).reshape(len(x), 4, 2))


def draw_route(img, affine, ppm, path: np.ndarray, colour, metres: float = 0.35) -> None:
    """A polyline through ``path`` (k, 2) world points (every 2 m is plenty)."""
    if len(path) >= 2:
        cv2.polylines(
            img, [to_fixed(affine, path)], False, colour, line_px(ppm, metres), cv2.LINE_AA, SHIFT
        )


def remaining_path(world, agent: int, every: float = 2.0) -> np.ndarray:
    """World points (k, 2) of ``agent``'s path from its progress to its end, about ``every`` m
    apart (the last one within ``every`` m of the end)."""
    k0 = int(world.s[agent] / PATH_SPACING)
    k1 = int(round(world.path_len[agent] / PATH_SPACING))
    return world.path[agent, k0 : k1 + 1 : max(1, int(every / PATH_SPACING))]


def light_groups(layer: StaticLayer, states: np.ndarray) -> tuple:
    """((colour, bar indices), …) for the lights in ``states``, one per colour shown, in
    palette order: what each ``fillPoly`` call draws. Cached on the layer: the lights cycle
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
    """:func:`draw_lights` with the bars ``layer.light_quads`` already in fixed-point pixels."""
    for colour, bars in light_groups(layer, states):
        cv2.fillPoly(img, quads[bars], colour, cv2.LINE_AA, SHIFT)


def agent_boxes(
    affine, ppm: float, world, idx: np.ndarray, grow: float = 0.0, min_px: float = MIN_AGENT_PX
) -> np.ndarray:
    """Fixed-point pixel footprints (len(idx), 4, 2) of ``idx``, ``grow`` m larger all round
    and at least ``min_px`` pixels a side."""
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
    """Draws agents at ``ppm`` pixels per metre, at least ``min_px`` pixels a side.

    Each world's agent shapes (body and windscreen corners in the agent's frame, as complex
    numbers) are computed once and cached, so a frame costs a fixed handful of numpy calls:
    corner = centre + e^{iθ} · offset, for all agents at once, then one ``fillPoly`` per colour.
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
            body = length * _CORNER_SIGNS.real + 1j * (width * _CORNER_SIGNS.imag)
            # windscreen: 18% of the length, centred 18% of it ahead of the centre, 80% wide
            fwd = 0.18 * length
            screen = fwd + fwd * _CORNER_SIGNS.real + 1j * (0.8 * width * _CORNER_SIGNS.imag)
            self._shapes = np.concatenate([body, screen], axis=1)
            self.screens = self.ppm * float(world.scene.car.length) >= 8.0  # a few pixels long
            self._groups.clear()
            self._lengths = world.length
        return self._shapes

    def corners(self, world, idx: np.ndarray) -> np.ndarray:
        """World corners (len(idx), 8, 2) of the bodies (4) and windscreens (4) of ``idx``."""
        shapes = self._shapes_of(world)[idx]
        st = world.state[idx]
        z = np.exp(1j * st[:, 2])[:, None] * shapes
        # + x + iy, the first complex of each state row (as floats x + 1j·y would be, but for
        # the sign of a zero part, which no pixel can show)
        z += st.view(np.complex128)[:, :1]
        return z.view(np.float64).reshape(len(idx), 8, 2)

    def draw(self, img, affine, world, idx: np.ndarray, ego: int = 0) -> None:
        """Cars (blue), pedestrians (orange) and the ego (magenta) among ``idx``; cars get a dark
        windscreen (it shows the heading) when they are at least 8 pixels long."""
        if len(idx):
            self.fill(img, to_fixed(affine, self.corners(world, idx)), world, idx, ego)

    def fill(self, img, px: np.ndarray, world, idx: np.ndarray, ego: int = 0) -> None:
        """:meth:`draw` with the :meth:`corners` already in fixed-point pixels ``px``."""
        for colour, rows, corners in self._groups_of(world, idx, ego):
            cv2.fillPoly(img, px[rows, corners], colour, cv2.LINE_AA, SHIFT)

    def _groups_of(self, world, idx: np.ndarray, ego: int) -> tuple:
        """((colour, rows of ``idx``, corners), …) for each non-empty ``fillPoly`` call, in
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


def add_pixel_noise(img: np.ndarray, std: float, rng: np.random.Generator) -> np.ndarray:
    """``img`` plus zero-mean Gaussian noise of standard deviation ``std`` (drawn from ``rng``),
    rounded to the nearest integer and saturated to [0, 255] by OpenCV."""
    noise = rng.standard_normal(img.shape, dtype=np.float32)
    noise *= std
    return cv2.add(img, noise, dtype=cv2.CV_8U)


# ----------------------------------------------------------------------------- the sensor
class BirdsEyeSensor:
    """Top-down RGB image of ``size`` × ``size`` pixels.

    ``frame="ego"``: a north-up square of side ``fov`` metres centred on the ego;
    ``"ego_rotated"``: the same square turned so that the ego faces up; ``"global"``: the whole
    layout (its bounds' enclosing square; ``fov`` unused). ``noise_var`` is λ_p.
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
        """The world → output-pixel affine (2×3) for the current state. In the ``"ego"`` frame
        the view is a crop of the static raster moved by whole pixels, so the ego sits within
        half a pixel of the image centre (and the background needs no resampling)."""
        return self._view(world, ego)[0]

    def _view(self, world, ego: int) -> tuple[np.ndarray, tuple[int, int] | None]:
        """:meth:`view` and, for a crop, the raster (row, column) of its top-left pixel."""
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
        """The static raster seen through ``affine``: a copy of it (global), a crop (ego frame
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
        agents. All their points go through the view in one :func:`to_fixed` call (each point's
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
