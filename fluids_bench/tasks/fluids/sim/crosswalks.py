"""Crosswalks as rectangles: which ones a pedestrian is on, and where each car route meets them.

One definition of "a crosswalk with a pedestrian on it" serves everything that asks: the
velocity planner's yield rule (`yield_to_pedestrians`), the check that the ego yielded
(`FaultTracker`) and the quasi-LIDAR v1, which
sees an occupied crosswalk's edges. A crosswalk is occupied when an active pedestrian's disc
(radius: half its width) overlaps its rectangle.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numba import njit

from fluids_bench.core.compiled import callee
from fluids_bench.tasks.fluids.sim.layout.compiled import CAR, Layout
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING

# A car is committed to a crosswalk (too close to stop for a walker who steps on now) when it
# is nearer than it covers in COMMIT_LATENCY s (two planning periods of the supervisor: it sees
# the walker at its next plan and the plan holds one period) plus braking at COMMIT_DECEL m/s²
# (60% of the planner's 5 m/s²). Walkers do not step out in front of a committed car, and a car
# is not blamed for driving onto a crosswalk that a walker stepped onto once it was committed.
COMMIT_LATENCY = 1.0
COMMIT_DECEL = 3.0


@dataclass(frozen=True, eq=False)
class Crosswalks:
    """A layout's C crosswalk rectangles and where each of its R routes meets them.

    `car_enter[r, c]`: the route arc length (m) at which a car on route `r` (front bumper)
    reaches crosswalk `c` (where its path enters the rectangle); `inf` where the route does
    not cross it, and for walks. `walk_crosswalk[r]`, `walk_enter[r]`: the crosswalk a walk
    `r` crosses (-1 for car routes and walks that cross none) and the arc length at which its
    path enters it, so a walker's front reaches it as its disc starts to overlap the rectangle.
    """

    centre: np.ndarray  # (C, 2)
    axis: np.ndarray  # (C, 2) unit vector along the crosswalk (across the road)
    half: np.ndarray  # (C, 2) half length, half width
    car_enter: np.ndarray  # (R, C)
    walk_crosswalk: np.ndarray  # (R,)
    walk_enter: np.ndarray  # (R,)

    @property
    def count(self) -> int:
        return len(self.centre)


@functools.lru_cache(maxsize=32)
def crosswalks_of(layout: Layout) -> Crosswalks:
    """The crosswalk rectangles of `layout` (cached per compiled layout)."""
    centre, axis, half = [], [], []
    for cw in layout.spec.crosswalks:
        p, q = np.asarray(cw.start, float), np.asarray(cw.end, float)
        centre.append((p + q) / 2)
        axis.append((q - p) / np.hypot(*(q - p)))
        half.append([np.hypot(*(q - p)) / 2, cw.width / 2])
    centre = np.array(centre, dtype=float).reshape(-1, 2)
    axis = np.array(axis, dtype=float).reshape(-1, 2)
    half = np.array(half, dtype=float).reshape(-1, 2)
    routes = layout.routes
    car_enter = np.full((len(routes.kind), len(centre)), np.inf)
    walk_crosswalk = np.full(len(routes.kind), -1, dtype=np.int64)
    walk_enter = np.full(len(routes.kind), np.inf)
    for r in range(len(routes.kind)):
        last = int(round(routes.length[r] / PATH_SPACING))
        rel = routes.path[r, : last + 1, None, :] - centre[None]  # (M, C, 2)
        along = np.abs(rel[..., 0] * axis[:, 0] + rel[..., 1] * axis[:, 1])
        across = np.abs(rel[..., 0] * axis[:, 1] - rel[..., 1] * axis[:, 0])
        # how far outside the rectangle each path sample is (<= 0: inside)
        outside = np.maximum(along - half[:, 0], across - half[:, 1])
        for c in np.flatnonzero((outside <= 0).any(axis=0)):
            s_in = _entry_arc_length(outside[:, c])
            if routes.kind[r] == CAR:
                car_enter[r, c] = s_in
            elif walk_crosswalk[r] < 0:  # a walk crosses one crosswalk
                walk_crosswalk[r], walk_enter[r] = c, s_in
    for arr in (centre, axis, half, car_enter, walk_crosswalk, walk_enter):
        arr.setflags(write=False)
    return Crosswalks(centre, axis, half, car_enter, walk_crosswalk, walk_enter)


def _entry_arc_length(outside: np.ndarray) -> float:
    """Arc length at which a path sampled every PATH_SPACING first enters a rectangle, its
    samples' distances `outside` it (<= 0 inside) interpolated linearly between samples."""
    first = int(np.argmax(outside <= 0))
    if first == 0:
        return 0.0
    before, after = outside[first - 1], outside[first]
    return (first - 1 + before / (before - after)) * PATH_SPACING


@njit(cache=True, inline="always")
def crosswalk_occupied(c, state, active, is_car, width, centre, axis, half):  # pragma: no cover
    """True when an active pedestrian's disc overlaps crosswalk `c`'s rectangle."""
    for j in range(len(state)):
        if is_car[j] or not active[j]:
            continue
        rx, ry = state[j, 0] - centre[c, 0], state[j, 1] - centre[c, 1]
        along = abs(rx * axis[c, 0] + ry * axis[c, 1])
        across = abs(rx * axis[c, 1] - ry * axis[c, 0])
        r = width[j] / 2
        if along <= half[c, 0] + r and across <= half[c, 1] + r:
            return True
    return False


@njit(cache=True)
def occupied_crosswalks(state, active, is_car, width, centre, axis, half, out):  # pragma: no cover
    """`out[c]` = `crosswalk_occupied` for every crosswalk; returns whether any is."""
    anyone = False
    for c in range(len(centre)):
        out[c] = crosswalk_occupied(c, state, active, is_car, width, centre, axis, half)
        anyone = anyone or out[c]
    return anyone


def occupied(world, cw: Crosswalks | None = None) -> np.ndarray:
    """Which of the world's crosswalks have a pedestrian on them now (bool (C,))."""
    cw = crosswalks_of(world.layout) if cw is None else cw
    out = np.zeros(cw.count, dtype=np.bool_)
    if cw.count:
        occupied_crosswalks(
            world.state, world.active, world.is_car, world.width, cw.centre, cw.axis, cw.half, out
        )
    return out


@njit(cache=True, inline="always")
def record_yield_step(
    route_s, front, route, active, is_car, car_enter, prev_at, prev_occ, warned, failed,
    state, width, centre, axis, half,
):  # fmt: skip  # pragma: no cover (compiled)
    """One step of the yield check, in place. An active car whose front reached a crosswalk on
    its route (`car_enter`) since the last step (`prev_at` < enter <= now) while that
    crosswalk was occupied (`prev_occ`, the last step's) failed to yield (`failed`) if it
    was `warned`: the crosswalk has been occupied since a step at which the car was not yet
    committed to it (`committed`), so it could have stopped. A walker who steps out in
    front of a car that can no longer stop is the walker's doing. Then `prev_at`,
    `prev_occ` and `warned` become this step's."""
    n_cw = len(centre)
    for i in range(len(route_s)):
        at = route_s[i] + front[i]
        if is_car[i] and active[i] and route[i] >= 0:
            for c in range(n_cw):
                enter = car_enter[route[i], c]
                if prev_occ[c] and warned[i, c] and prev_at[i] < enter <= at:
                    failed[i] = True
        prev_at[i] = at
    occupied_crosswalks(state, active, is_car, width, centre, axis, half, prev_occ)
    for i in range(len(route_s)):
        if not (is_car[i] and active[i] and route[i] >= 0):
            continue
        for c in range(n_cw):
            if not prev_occ[c]:
                warned[i, c] = False
            elif car_enter[route[i], c] - prev_at[i] >= stopping_reach(state[i, 3]):
                warned[i, c] = True


@njit(cache=True)
def stopping_reach(v):  # pragma: no cover (compiled)
    """How far short of a crosswalk a car at `v` m/s must be to stop for a walker who steps
    on now: what it covers in `COMMIT_LATENCY` plus braking at `COMMIT_DECEL`.
    Closer than that (and not past it) the car is *committed* to the crosswalk."""
    return v * COMMIT_LATENCY + v * v / (2.0 * COMMIT_DECEL)


def committed_crosswalks(world, front: np.ndarray, turning_out: np.ndarray | None = None):
    """Crosswalks (bool (C,)) that an active car is committed to: too close to stop for a
    walker stepping on now (`stopping_reach`), or, for the cars marked in
    `turning_out` (bool (N,); default none), already inside the junction on its way out
    across it, so that a walker stepping out does not strand such a car in the box."""
    cw = crosswalks_of(world.layout)
    if turning_out is None:
        turning_out = np.zeros(world.n, dtype=bool)
    return committed_to(
        world.state, world.s, world.offset, front, world.is_car, world.active, world.route,
        world.entered, turning_out, cw.car_enter,
    )  # fmt: skip


@callee
def committed_to(
    state, s, offset, front, is_car, active, route, entered, turning_out, car_enter
):  # pragma: no cover (compiled)
    """`committed_crosswalks` over the world's arrays (`car_enter` (R, C): where each
    car route meets each crosswalk)."""
    busy = np.zeros(car_enter.shape[1], np.bool_)
    for i in range(len(s)):
        if not (is_car[i] and active[i] and route[i] >= 0):
            continue
        at = s[i] + offset[i] + front[i]
        reach = stopping_reach(state[i, 3])
        inside = entered[i] >= 0 and turning_out[i]
        for c in range(car_enter.shape[1]):
            gap = car_enter[route[i], c] - at
            busy[c] |= gap > 0 and (gap < reach or inside)
    return busy
