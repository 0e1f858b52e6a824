"""Layout builders: a four-way intersection, a T-junction and a roundabout.

All are built from "arms": straight roads meeting at the origin, each with `lanes` inbound and
`lanes` outbound lanes (right-hand traffic). Inbound lanes end at a stop line just before the
arm's crosswalk; outbound lanes start just after it. Distances in metres, times in seconds.
"""

from __future__ import annotations

import math

import numpy as np

from fluids_bench.tasks.fluids.sim.layout.geometry import arc
from fluids_bench.tasks.fluids.sim.layout.spec import (
    CarRoute,
    Crosswalk,
    Lane,
    LayoutSpec,
    Light,
    Walk,
)

ARM_NAMES = {0: "east", 90: "north", 180: "west", 270: "south"}
KERB_RADIUS = 6.0  # m, rounds every corner between roads


def _unit(deg: float) -> np.ndarray:
    return np.array([math.cos(math.radians(deg)), math.sin(math.radians(deg))])


def _right(deg: float) -> np.ndarray:
    """Unit normal to the right of heading `deg`."""
    return np.array([math.sin(math.radians(deg)), -math.cos(math.radians(deg))])


def _pt(v: np.ndarray) -> tuple[float, float]:
    return (round(float(v[0]), 6), round(float(v[1]), 6))


def _check_choice(name: str, value, allowed) -> None:
    if value not in allowed:
        raise ValueError(f"layout builder: field '{name}' is {value!r}; allowed: {list(allowed)}")


def _check_range(name: str, value, lo: float, hi: float) -> None:
    if not isinstance(value, int | float) or not lo <= value <= hi:
        raise ValueError(f"layout builder: field '{name}' is {value!r}; allowed: [{lo}, {hi}]")


def _signal_lights(arm_angles, phase_of, green, yellow, all_red, crosswalk_lights):
    """Two-phase signal: arms with phase 0 go, then arms with phase 1.

    Each phase is green then yellow then an all-red clearance. A crosswalk across an arm shows
    white while that arm's own traffic is stopped by red, and turns red `all_red + yellow`
    seconds before that red ends, so walkers clear before the arm's cars move.
    """
    half = green + yellow + all_red
    cycle = 2 * half
    lights = []
    for deg in arm_angles:
        start = phase_of[deg] * half  # when this arm turns green
        lights.append(
            Light(
                f"tl_{ARM_NAMES[deg]}",
                "traffic",
                (0.0, 0.0),
                (("green", green), ("yellow", yellow), ("red", cycle - green - yellow)),
                offset=-start % cycle,
            )
        )
        if crosswalk_lights:
            white = max(1.0, green - yellow)
            lights.append(
                Light(
                    f"cw_{ARM_NAMES[deg]}",
                    "crosswalk",
                    (0.0, 0.0),
                    (("white", white), ("red", cycle - white)),
                    offset=-(start + half) % cycle,
                )
            )
    return lights


def _corner_arc(src: float, dst: float, offset: float, corner: float, left: bool):
    """A turn concentric with the kerb between arms `src` and `dst`: it starts where the kerb
    starts curving (`corner` m from the centre), `offset` m from the road's centre line, so
    the car keeps its lane's distance from the kerb all the way round."""
    centre = corner * (_unit(src) + _unit(dst))
    start = corner * _unit(src) + offset * _right(src + 180)
    end = corner * _unit(dst) + offset * _right(dst)
    a0 = math.atan2(*(start - centre)[::-1])
    a1 = math.atan2(*(end - centre)[::-1])
    if left:
        a1 += 2 * math.pi if a1 <= a0 else 0.0
    else:
        a1 -= 2 * math.pi if a1 >= a0 else 0.0
    radius = float(np.hypot(*(start - centre)))
    return tuple(_pt(p) for p in arc(centre, radius, a0, a1, 0.5))


def _arms(
    arm_angles,
    lanes,
    lane_width,
    lane_length,
    curb_radius,
    crosswalk_width,
    speed_limit,
    lights_on,
    core,
    turn_via=None,
):
    """Lanes, routes, crosswalks and walks for arms at `arm_angles` (degrees)."""
    hw = lanes * lane_width  # road half-width
    cw_mid = core + curb_radius + crosswalk_width / 2  # crosswalk centre, from the origin
    stop = core + curb_radius + crosswalk_width + 0.5  # stop line distance from the origin
    far = stop + lane_length
    lane_objs, routes, crosswalks, walks, roads = [], [], [], [], []
    sidewalk_off = hw + 1.25
    for deg in arm_angles:
        u, inbound = _unit(deg), deg + 180
        name = ARM_NAMES[deg]
        n = _right(deg)
        roads.append(tuple(_pt(p) for p in (hw * n, far * u + hw * n, far * u - hw * n, -hw * n)))
        for i in range(lanes):
            off = (i + 0.5) * lane_width
            lane_objs.append(
                Lane(
                    f"{name}_in_{i}",
                    (_pt(far * u + off * _right(inbound)), _pt(stop * u + off * _right(inbound))),
                    lane_width,
                    speed_limit,
                    f"tl_{name}" if lights_on else None,
                )
            )
            lane_objs.append(
                Lane(
                    f"{name}_out_{i}",
                    (_pt(stop * u + off * _right(deg)), _pt(far * u + off * _right(deg))),
                    lane_width,
                    speed_limit,
                )
            )
        a = cw_mid * u + (hw + 0.5) * _right(inbound)
        b = cw_mid * u + (hw + 0.5) * _right(deg)
        crosswalks.append(
            Crosswalk(
                f"cw_{name}", _pt(a), _pt(b), crosswalk_width, f"cw_{name}" if lights_on else None
            )
        )
        # walks: along the sidewalk towards the crosswalk, across it, then back out along the arm
        for side, sign in (("r", 1), ("l", -1)):
            p0 = (cw_mid + 8) * u + sign * sidewalk_off * _right(inbound)
            p1 = cw_mid * u + sign * sidewalk_off * _right(inbound)
            p2 = cw_mid * u - sign * sidewalk_off * _right(inbound)
            p3 = (cw_mid + 8) * u - sign * sidewalk_off * _right(inbound)
            walks.append(Walk(f"walk_{name}_{side}", tuple(_pt(p) for p in (p0, p1, p2, p3))))
    for deg in arm_angles:
        others = sorted((d for d in arm_angles if d != deg), key=lambda d: (d - deg) % 360)
        for target in others:
            turn = (target - (deg + 180)) % 360  # 90: left turn, 270: right turn, 0: straight
            for i in range(lanes):
                if lanes > 1 and ((turn == 90 and i != 0) or (turn == 270 and i != lanes - 1)):
                    continue  # left turns from the inner lane, right turns from the outer
                j = 0 if turn == 90 else lanes - 1 if turn == 270 else i
                if turn_via is not None:
                    via = turn_via(deg, target, i, j)
                elif turn == 0:
                    via = ()
                else:
                    via = _corner_arc(
                        deg, target, (i + 0.5) * lane_width, hw + curb_radius, turn == 90
                    )
                routes.append(
                    CarRoute(f"{ARM_NAMES[deg]}_in_{i}", f"{ARM_NAMES[target]}_out_{j}", via)
                )
    return lane_objs, routes, crosswalks, walks, roads, far


def _junction(
    kind: str,
    arm_angles,
    lanes,
    lights,
    pedestrians,
    lane_length,
    lane_width,
    speed_limit,
    green,
    yellow,
    all_red,
    core=None,
    turn_via=None,
    islands=(),
):
    _check_choice("lanes", lanes, (1, 2))
    _check_range("lane_length", lane_length, 10.0, 500.0)
    _check_range("lane_width", lane_width, 2.5, 5.0)
    _check_range("speed_limit", speed_limit, 1.0, 40.0)
    for name, v in (("green", green), ("yellow", yellow), ("all_red", all_red)):
        _check_range(name, v, 0.5, 300.0)
    curb, cw_width = KERB_RADIUS, 3.0
    hw = lanes * lane_width
    core = hw if core is None else core
    lane_objs, routes, crosswalks, walks, roads, far = _arms(
        arm_angles,
        lanes,
        lane_width,
        lane_length,
        curb,
        cw_width,
        speed_limit,
        lights,
        core,
        turn_via,
    )
    light_objs = []
    if lights:
        phase_of = {d: (0 if d % 180 == 0 else 1) for d in arm_angles}
        light_objs = _signal_lights(arm_angles, phase_of, green, yellow, all_red, pedestrians)
    if not pedestrians:
        crosswalks, walks = [], []
    # the arms' full road width from the centre out, plus a roundabout's disc
    areas = tuple(roads)
    if kind == "roundabout":
        areas += (tuple(_pt(p) for p in arc((0, 0), core, 0, 2 * math.pi, 1.0)[:-1]),)
    return LayoutSpec(
        name=kind,
        bounds=(-far, -far, far, far),
        lanes=tuple(lane_objs),
        routes=tuple(routes),
        crosswalks=tuple(crosswalks),
        lights=tuple(light_objs),
        walks=tuple(walks),
        areas=areas,
        islands=islands,
        curb_radius=curb,
        sidewalk_width=2.5 if pedestrians else 0.0,
    )


def four_way(
    lanes: int = 1,
    lights: bool = True,
    pedestrians: bool = True,
    lane_length: float = 30.0,
    lane_width: float = 3.5,
    speed_limit: float = 10.0,
    green: float = 12.0,
    yellow: float = 3.0,
    all_red: float = 2.0,
) -> LayoutSpec:
    """A four-way intersection, `lanes` (1 or 2) per direction, with sidewalks, crosswalks and
    (if `lights`) a two-phase signal: east-west green, then north-south green."""
    return _junction(
        "four_way",
        (0, 90, 180, 270),
        lanes,
        lights,
        pedestrians,
        lane_length,
        lane_width,
        speed_limit,
        green,
        yellow,
        all_red,
    )


def t_junction(
    lanes: int = 1,
    lights: bool = True,
    pedestrians: bool = True,
    lane_length: float = 30.0,
    lane_width: float = 3.5,
    speed_limit: float = 10.0,
    green: float = 12.0,
    yellow: float = 3.0,
    all_red: float = 2.0,
) -> LayoutSpec:
    """A T-junction: an east-west road with a southern arm; signalised like `four_way`."""
    return _junction(
        "t_junction",
        (0, 180, 270),
        lanes,
        lights,
        pedestrians,
        lane_length,
        lane_width,
        speed_limit,
        green,
        yellow,
        all_red,
    )


def roundabout(
    radius: float = 12.0,
    pedestrians: bool = True,
    lane_length: float = 30.0,
    lane_width: float = 3.5,
    speed_limit: float = 10.0,
) -> LayoutSpec:
    """A single-lane, four-arm roundabout (counter-clockwise circulation), no signals: entering
    cars yield through the velocity planner; walkers cross at unsignalised crosswalks."""
    _check_range("radius", radius, 8.0, 60.0)
    ring = radius  # centre line of the circulating lane
    outer = ring + lane_width / 2

    # entering and leaving follow the kerb between arm and ring: an arc concentric with the kerb
    # corner F (arm frame: x out along the arm, y to its left), lane_width / 2 from the kerb
    lw = lane_width
    fy = lw + KERB_RADIUS
    fx = math.sqrt((outer + KERB_RADIUS) ** 2 - fy**2)
    bend = KERB_RADIUS + lw / 2
    enter = arc((fx, fy), bend, -math.pi / 2, math.atan2(-fy, -fx), 0.5)  # clockwise: a right turn
    leave = (enter * [1.0, -1.0])[::-1]  # the mirror image, driven the other way
    touch = math.atan2(fy, fx)  # where the entry meets the ring, seen from the centre

    def rotate(pts: np.ndarray, deg: float) -> np.ndarray:
        c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
        return pts @ np.array([[c, s], [-s, c]])

    def via(src: int, dst: int, _i: int, _j: int):
        a0 = math.radians(src) + touch
        a1 = math.radians(dst) - touch
        while a1 <= a0:
            a1 += 2 * math.pi
        ring_arc = arc((0, 0), ring, a0, a1, 0.5)
        pts = np.vstack([rotate(enter, src), ring_arc[1:-1], rotate(leave, dst)])
        return tuple(_pt(p) for p in pts)

    island = tuple(_pt(p) for p in arc((0, 0), ring - lane_width / 2, 0, 2 * math.pi, 1.0)[:-1])
    return _junction(
        "roundabout",
        (0, 90, 180, 270),
        1,
        False,
        pedestrians,
        lane_length,
        lane_width,
        speed_limit,
        1.0,
        1.0,
        1.0,
        core=outer,
        turn_via=via,
        islands=(island,),
    )


BUILDERS = {"four_way": four_way, "t_junction": t_junction, "roundabout": roundabout}


def build_layout(name: str, **kwargs) -> LayoutSpec:
    """Build the layout `name` (one of `BUILDERS`) with builder `kwargs`."""
    if name not in BUILDERS:
        raise ValueError(f"layout: '{name}' is unknown; allowed: {sorted(BUILDERS)}")
    return BUILDERS[name](**kwargs)
