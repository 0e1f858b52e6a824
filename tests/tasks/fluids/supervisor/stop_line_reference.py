"""The velocity planner's stop lines as the numpy formulation that
:func:`fluids_bench.tasks.fluids.supervisor.stop_line_kernels.stop_lines` replaced (the
planner's methods as they were, taking the planner as ``self``, and the crosswalk helpers they
called): a reference for ``test_stop_line_kernel.py``.
"""

from __future__ import annotations

import numpy as np

from fluids_bench.tasks.fluids.sim.crosswalks import crosswalks_of, occupied, stopping_reach
from fluids_bench.tasks.fluids.sim.lights import CAUTION, STOP
from fluids_bench.tasks.fluids.sim.world import World


def _hold_before(stop: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """allowed[a, k]: False where candidate k takes agent a past its stop arc length ``stop``
    (``inf``: none) within the horizon (``reach``, (A, K)), unless even braking (k = 0) does."""
    blocked = reach > stop[:, None]
    can_stop = ~blocked[:, 0]  # the slowest candidate stops in time
    return ~(blocked & can_stop[:, None])


def reference_domains_and_hold_lines(
    self, world: World, agents: np.ndarray, s_proj: np.ndarray, uncontrolled=None
) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`domains`, and the route arc length (A,) of the first stop line each agent
    will hold before (one it can still stop for; ``inf`` where none)."""
    allowed = np.ones(s_proj.shape[:2], dtype=bool)
    line = np.full(len(agents), np.inf)
    reach = s_proj[:, :, -1] + (world.offset[agents] + self._front[agents])[:, None]
    for stop in _stop_lines(self, world, agents, uncontrolled):
        allowed &= _hold_before(stop, reach)
        line = np.minimum(line, np.where(reach[:, 0] <= stop, stop, np.inf))
    return allowed, line


def _stop_lines(self, world: World, agents: np.ndarray, uncontrolled=None) -> list:
    """Route arc lengths at which each agent's front must hold, one array per kind of
    stop (red and yellow lights; with ``yield_to_pedestrians``, occupied crosswalks and,
    for walkers, the kerb); ``inf`` where none holds it."""
    front = self._front[agents]
    stops = []
    light = _light_stops(self, world, agents, front)
    if light is not None:
        stops.append(light)
    if self.config.yield_to_pedestrians and self._crosswalks.count:
        occ = occupied(world, self._crosswalks)
        if occ.any():
            stops.append(next_occupied_enter(world, agents, occ, front))
        stops.append(_kerb_stops(self, world, agents, uncontrolled))
    return stops


def _kerb_stops(self, world: World, agents: np.ndarray, uncontrolled=None) -> np.ndarray:
    """Walkers wait at the kerb (where their disc would start to overlap the crosswalk)
    while a car is committed to that crosswalk (too close to stop for them, see
    :func:`~fluids_bench.tasks.fluids.sim.crosswalks.stopping_reach`), so a car that
    yields is not cut off by a walker stepping out in front of it; and while a supervised
    car turning left is inside the junction on its way out across it, so that a walker
    does not strand it across the oncoming lane (``uncontrolled``, (N,) bool: the cars
    that do not count; a learner's ego still has to stop for a walker who steps out)."""
    cw = self._crosswalks
    walk_cw = cw.walk_crosswalk[world.route[agents]]
    kerb = cw.walk_enter[world.route[agents]]
    waiting = (walk_cw >= 0) & (world.route_s[agents] + self._front[agents] < kerb)
    if not waiting.any():
        return np.full(len(agents), np.inf)
    route = np.maximum(world.route, 0)
    turning_out = self._turns[1][route] & (world.route >= 0) & world.is_car
    if uncontrolled is not None:
        turning_out &= ~uncontrolled
    busy = committed_crosswalks_numpy(world, self._front, turning_out)
    return np.where(waiting & busy[np.maximum(walk_cw, 0)], kerb, np.inf)


def _light_stops(self, world: World, agents: np.ndarray, front: np.ndarray):
    """Each agent's stop line where its light holds it (red; yellow if it can still brake
    comfortably, and so, with ``yield_to_pedestrians``, a walker's white light about to
    turn red: :meth:`_dont_walk`), ``inf`` where none does; None when no light holds
    anyone."""
    routes = world.layout.routes
    r = world.route[agents]
    light = routes.light[r]
    if not len(world.light_state) or (light < 0).all():
        return None
    stop_s = routes.stop_s[r]
    gap = stop_s - (world.route_s[agents] + front)
    state = world.light_state[np.maximum(light, 0)]
    v = world.state[agents, 3]
    brake = v**2 / (2 * 0.6 * self.config.max_decel)  # comfortable braking distance
    caution = state == CAUTION
    if self.config.yield_to_pedestrians:
        caution |= _dont_walk(self, world, agents, light, state, gap)
    holds = (light >= 0) & (gap > -0.5) & ((state == STOP) | (caution & (brake < gap)))
    if not holds.any():
        return None
    return np.where(holds, stop_s, np.inf)


def _dont_walk(self, world: World, agents: np.ndarray, light, state, gap) -> np.ndarray:
    """Walkers whose white light turns red before they would reach their crosswalk (at
    their speed, or half a walking pace from rest, plus a planning period): a flashing
    "don't walk" that crosswalk lights lack; without it, a walker just short of the
    kerb when the light turns red cannot stop and enters on red."""
    walker = ~world.is_car[agents] & (light >= 0) & (state != STOP) & (gap > 0)
    if not walker.any():
        return walker
    left = world.lights.time_to_change(world.time)[np.maximum(light, 0)]
    pace = np.maximum(world.state[agents, 3], 0.5 * world.max_speed[agents])
    return walker & (left < gap / pace + self.config.period * world.dt)


def next_occupied_enter(world, agents: np.ndarray, occ: np.ndarray, front: np.ndarray):
    """For each of ``agents``: the route arc length at which its front reaches the nearest
    occupied crosswalk (``occ``) still ahead of its front, ``inf`` if none."""
    cw = crosswalks_of(world.layout)
    r = np.maximum(world.route[agents], 0)
    enter = cw.car_enter[r][:, occ]  # (A, occupied)
    at = world.route_s[agents] + front
    enter = np.where((enter > at[:, None]) & (world.route[agents] >= 0)[:, None], enter, np.inf)
    return enter.min(axis=1) if enter.shape[1] else np.full(len(agents), np.inf)


def committed_crosswalks_numpy(world, front: np.ndarray, turning_out: np.ndarray | None = None):
    """Crosswalks (bool (C,)) that an active car is committed to: too close to stop for a
    walker stepping on now (:func:`stopping_reach`), or, for the cars marked in
    ``turning_out`` (bool (N,); default none), already inside the junction on its way out
    across it, so that a walker stepping out does not strand such a car in the box."""
    cw = crosswalks_of(world.layout)
    cars = np.flatnonzero(world.is_car & world.active & (world.route >= 0))
    if not len(cars) or not cw.count:
        return np.zeros(cw.count, dtype=bool)
    r = world.route[cars]
    at = world.route_s[cars] + front[cars]
    gap = cw.car_enter[r] - at[:, None]
    v = world.state[cars, 3]
    near = gap < stopping_reach(v)[:, None]
    if turning_out is not None:  # inside the junction: its front has reached its zone
        near |= ((world.entered[cars] >= 0) & turning_out[cars])[:, None]
    return ((gap > 0) & near).any(axis=0)
