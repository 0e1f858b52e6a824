"""The velocity planner's unary constraints in one compiled call (numba): stop lines.

Each plan, every agent may have to hold before a stop line: its light (red; yellow if it can
still brake comfortably; for a walker, a white light that turns red before it would reach the
crosswalk), with `yield_to_pedestrians` the nearest occupied crosswalk ahead of a car, and
for a walker the kerb while a car is committed to its crosswalk. A candidate speed that takes
the agent past a line it can still stop for is pruned. As numpy this was some 50 array calls
per plan on a dozen agents; here it is one pass over the agents.

Pure function over arrays with no Python objects, so a batch of worlds can be walked the same
way. The arithmetic is the numpy formulation's, operation for operation in float64 (no
transcendental function; the light phase is the floored modulo numpy and Python share).
`tests/tasks/fluids/supervisor/stop_line_reference.py` keeps that formulation and
`test_stop_line_kernel.py` compares bit for bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fluids_bench.core.compiled import callee
from fluids_bench.tasks.fluids.sim.crosswalks import committed_to, crosswalk_occupied
from fluids_bench.tasks.fluids.sim.lights import CAUTION, STOP


@njit(cache=True, nogil=True, inline="always")
def _wrapped(index, n):  # pragma: no cover (compiled)
    """numpy's reading of a negative index (-1: the last)."""
    return index if index >= 0 else index + n


@njit(cache=True, nogil=True, inline="always")
def _time_to_change(light, t, ends, cycle, offset):  # pragma: no cover (compiled)
    """Seconds until `light` next changes state (LightProgram.time_to_change)."""
    phase_t = (t + offset[light]) % cycle[light]
    nxt = np.inf
    for e in ends[light]:
        if e > phase_t:
            nxt = min(nxt, e)
    return nxt - phase_t


@callee
def stop_lines(
    agents, front_a, s_proj,
    state, s, offset, front, is_car, active, width, route, entered, max_speed, uncontrolled,
    route_light, stop_s, light_state, ends, cycle, light_offset, t,
    cw_centre, cw_axis, cw_half, car_enter, walk_crosswalk, walk_enter, turning,
    max_decel, yield_to_pedestrians, plan_period_s,
):  # fmt: skip  # pragma: no cover (compiled)
    """(allowed (A, K), line (A,), stops (3, A)) of the planned `agents` (world indices),
    whose fronts are `front_a` (m) and projections `s_proj` (A, K, T) (path arc lengths).

    stops: the route arc length at which each agent's front must hold, per kind (its light,
    the nearest occupied crosswalk ahead, the kerb), `inf` where none holds it. allowed[a, k]
    is False where candidate k takes agent a past a line it can still stop for (the slowest
    candidate stops before it) within the horizon; line: the first such line (`inf`: none).

    World arrays (N, ...); `uncontrolled` (N,) bool: cars whose left turn out of the
    junction does not hold walkers at the kerb. Routes: `route_light` (R,) (-1: none),
    `stop_s` (R,). Lights: states now, phase `ends` (L, W), `cycle` and
    `light_offset` (L,), time `t` (s). Crosswalks: rectangles (C, 2) each, where car
    routes meet them `car_enter` (R, C), each walk's crosswalk and entry. `turning` (R,):
    the routes that turn left. `plan_period_s`: the planning period (s).
    """
    n_agents, n_cand = s_proj.shape[0], s_proj.shape[1]
    n_routes, n_cw = len(stop_s), len(cw_centre)
    stops = np.full((3, n_agents), np.inf)
    # lights: red holds; yellow (and a walker's white light about to turn red) holds an agent
    # that can still brake comfortably; an agent committed past its line (0.5 m) is not held
    if len(light_state):
        for a in range(n_agents):
            ag = agents[a]
            r = _wrapped(route[ag], n_routes)
            light = route_light[r]
            if light < 0:
                continue
            gap = stop_s[r] - (s[ag] + offset[ag] + front_a[a])
            code = light_state[light]
            v = state[ag, 3]
            brake = v * v / (2 * 0.6 * max_decel)  # comfortable braking distance
            caution = code == CAUTION
            if yield_to_pedestrians and not is_car[ag] and code != STOP and gap > 0:
                # a flashing "don't walk": its light turns red before it would get there
                left = _time_to_change(light, t, ends, cycle, light_offset)
                pace = max(v, 0.5 * max_speed[ag])
                caution |= left < gap / pace + plan_period_s
            if gap > -0.5 and (code == STOP or (caution and brake < gap)):
                stops[0, a] = stop_s[r]
    if yield_to_pedestrians and n_cw:
        occ = np.zeros(n_cw, np.bool_)
        for c in range(n_cw):
            occ[c] = crosswalk_occupied(
                c, state, active, is_car, width, cw_centre, cw_axis, cw_half
            )
        if occ.any():  # a car holds before the nearest occupied crosswalk still ahead of it
            for a in range(n_agents):
                ag = agents[a]
                if route[ag] < 0:
                    continue
                at = s[ag] + offset[ag] + front_a[a]
                for c in range(n_cw):
                    enter = car_enter[route[ag], c]
                    if occ[c] and enter > at:
                        stops[1, a] = min(stops[1, a], enter)
        # a walker waits at the kerb while a car is committed to its crosswalk
        waiting = np.zeros(n_agents, np.bool_)
        for a in range(n_agents):
            ag = agents[a]
            r = _wrapped(route[ag], n_routes)
            waiting[a] = walk_crosswalk[r] >= 0 and s[ag] + offset[ag] + front_a[a] < walk_enter[r]
        if waiting.any():
            turning_out = np.zeros(len(s), np.bool_)
            for i in range(len(s)):
                turning_out[i] = (
                    turning[max(route[i], 0)] and route[i] >= 0 and is_car[i]
                ) and not uncontrolled[i]
            busy = committed_to(
                state, s, offset, front, is_car, active, route, entered, turning_out, car_enter
            )
            for a in range(n_agents):
                r = _wrapped(route[agents[a]], n_routes)
                if waiting[a] and busy[max(walk_crosswalk[r], 0)]:
                    stops[2, a] = walk_enter[r]
    allowed = np.ones((n_agents, n_cand), np.bool_)
    line = np.full(n_agents, np.inf)
    last = s_proj.shape[2] - 1
    for a in range(n_agents):
        ag = agents[a]
        ahead = offset[ag] + front_a[a]
        for kind in range(3):
            stop = stops[kind, a]
            if not s_proj[a, 0, last] + ahead <= stop:
                continue  # even braking passes it: not held back
            line[a] = min(line[a], stop)
            for k in range(n_cand):
                allowed[a, k] &= not s_proj[a, k, last] + ahead > stop
    return allowed, line, stops
