"""The velocity planner's tick as two compiled calls (`VelocityPlanner.plan`).

`plan_head` chains what comes before the distances between footprint circles (allowed
speeds, candidates, projection, stop lines, defensive domains, candidate pairs);
`plan_tail` what comes after (pair conflicts, the CSP). In between, the planner takes the
distances with numpy's complex abs, the reference's (its vectorised loop may differ from the C
library's `hypotf` in the last bit, so it stays numpy's). Each step is the kernel the
planner's methods call one by one, in the same order on the same arrays: one Python call per
half instead of seven, and no numpy temporaries in between.

`plan_head_worlds` and `plan_tail_worlds` are the two halves for every due world of
a batch (rows of (B, ...) arrays), with numpy's abs taken once over all their gaps between them:
numpy's complex abs gives each element the same bits wherever it lies in an array (its SIMD
loop loads a short tail masked, not through a scalar loop), which the batch's equality tests
check against the scalar env.
"""

from __future__ import annotations

import numpy as np
from numba.typed import List

from fluids_bench.core.compiled import kernel
from fluids_bench.tasks.fluids.supervisor.csp_kernels import plan_choice
from fluids_bench.tasks.fluids.supervisor.defensive_kernels import defensive_forbid
from fluids_bench.tasks.fluids.supervisor.kernels import (
    allowed_speeds,
    circle_gaps,
    plan_conflicts,
    projected_arc_lengths,
)
from fluids_bench.tasks.fluids.supervisor.stop_line_kernels import stop_lines


@kernel
def plan_head(
    agents, uncontrolled, fractions,
    state, s, offset, front, is_car, active, width, route, entered, max_speed, brake_limit,
    curvature, speed_limit, enter_s, route_light, stop_s, across,
    light_state, ends, cycle, light_offset, t,
    cw_centre, cw_axis, cw_half, car_enter, walk_crosswalk, walk_enter, turning,
    offs, radius, reach, path_c64, path_dir, decay, hold_wild, ints, floats, look,
    yield_to_pedestrians, defensive,
):  # fmt: skip  # pragma: no cover (compiled)
    """(targets (A, K), s_proj (A, K, T), allowed (A, K), first, second (P,), gaps (P, 9)) of
    the planned `agents`: candidate speeds, their projections, the unary constraints (stop
    lines; with `defensive`, toward the `uncontrolled` agents) and the candidate pairs with
    their circle gaps now. Arguments as `defensive_kernels.defensive_forbid` and
    `stop_line_kernels.stop_lines` take them; `ints` and `floats` are the defensive
    kernel's (period, horizon steps, give-way steps, sample_every, look-ahead samples; dt,
    max_accel, max_decel, speed_gain, margin, pedestrian_margin, lateral_accel, path spacing,
    stationary speed); `look`: path samples ahead whose curvature limits the speed now."""
    period, steps, every = ints[0], ints[1], ints[3]
    dt, max_accel, max_decel, gain = floats[0], floats[1], floats[2], floats[3]
    lateral_accel, spacing = floats[6], floats[7]
    vmax = allowed_speeds(
        agents, s, offset, route, is_car, max_speed, curvature, speed_limit, look,
        lateral_accel, spacing,
    )  # fmt: skip
    n_agents, n_cand = len(agents), len(fractions)
    targets = np.empty((n_agents, n_cand))
    s0, v0 = np.empty(n_agents), np.empty(n_agents)
    for a in range(n_agents):
        for k in range(n_cand):
            targets[a, k] = vmax[a] * fractions[k]
        s0[a], v0[a] = s[agents[a]], state[agents[a], 3]
    s_proj = projected_arc_lengths(
        s0, v0, targets, decay, steps, every, dt, max_accel, max_decel, gain
    )
    front_a = np.empty(n_agents)
    for a in range(n_agents):
        front_a[a] = front[agents[a]]
    allowed, hold, _ = stop_lines(
        agents, front_a, s_proj,
        state, s, offset, front, is_car, active, width, route, entered, max_speed, uncontrolled,
        route_light, stop_s, light_state, ends, cycle, light_offset, t,
        cw_centre, cw_axis, cw_half, car_enter, walk_crosswalk, walk_enter, turning,
        max_decel, yield_to_pedestrians, period * dt,
    )  # fmt: skip
    if defensive:
        wild = np.empty(n_agents, np.bool_)
        for a in range(n_agents):
            wild[a] = uncontrolled[agents[a]]
        if wild.any():
            forbid = defensive_forbid(
                agents, wild, targets, hold,
                state, s, offset, front, is_car, entered, route, max_speed, brake_limit,
                offs, radius, reach, path_c64, path_dir,
                enter_s, across, curvature, speed_limit,
                fractions, hold_wild, ints, floats,
            )  # fmt: skip
            allowed &= ~forbid
    first, second, gaps = circle_gaps(agents, state, is_car, offs)
    return targets, s_proj, allowed, first, second, gaps


@kernel
def plan_tail(
    agents, targets, s_proj, allowed, first, second, gap_abs,
    state, s, offset, front, is_car, route, enter_s,
    offs, radius, reach, path_c64, path_dir, inv_spacing, margin, pedestrian_margin, out,
):  # fmt: skip  # pragma: no cover (compiled)
    """The CSP's pairs and conflicts (`kernels.plan_conflicts`, none without candidate
    pairs) and its answer (`csp_kernels.plan_choice`); writes each agent's chosen target
    into `out` (N,) and returns whether the CSP was solved. `gap_abs` (P, 9): numpy's abs
    of the circle gaps; their minimum per pair (exact, as numpy's `min(axis=1)`) is the
    distance now."""
    if len(first):
        d_now = np.empty(len(first), gap_abs.dtype)
        for p in range(len(first)):
            d = gap_abs[p, 0]
            for k in range(1, gap_abs.shape[1]):
                d = min(d, gap_abs[p, k])
            d_now[p] = d
        pairs, conflict = plan_conflicts(
            agents, s_proj, first, second, d_now,
            state, s, offset, front, is_car, route, enter_s,
            offs, radius, reach, path_c64, path_dir, inv_spacing, margin, pedestrian_margin,
        )  # fmt: skip
    else:
        n_cand = targets.shape[1]
        pairs = np.zeros((0, 2), np.int64)
        conflict = np.zeros((0, n_cand, n_cand), np.bool_)
    choice, solved = plan_choice(agents, s, offset, front, route, enter_s, allowed, pairs, conflict)
    for a in range(len(agents)):
        out[agents[a]] = targets[a, choice[a]]
    return solved


@kernel
def plan_head_worlds(
    due, uncontrolled, fractions,
    state, s, offset, front, is_car, active, width, route, entered, max_speed, brake_limit,
    curvature, speed_limit, enter_s, route_light, stop_s, across,
    light_state, ends, cycle, light_offset, times,
    cw_centre, cw_axis, cw_half, car_enter, walk_crosswalk, walk_enter, turning,
    offs, radius, reach, path_c64, path_dir, decay, hold_wild, ints, floats, look,
    yield_to_pedestrians, defensive,
):  # fmt: skip  # pragma: no cover (compiled)
    """`plan_head` of world `b` for each `b` in `due`, its planned agents the
    active ones. The per-world arrays (`state` … `entered`, `light_state`, `times`,
    `path_c64`, `path_dir`) are rows (B, ...); the others are the scene's. Returns each
    due world's (agents, targets, s_proj, allowed, first, second), all their gaps stacked
    (P, 9), and where each world's start in them (len(due) + 1,)."""
    heads = List()
    chunks = List()
    starts = np.zeros(len(due) + 1, np.int64)
    n_cand = len(fractions)
    for j in range(len(due)):
        b = due[j]
        agents = np.flatnonzero(active[b])
        if len(agents):
            targets, s_proj, allowed, first, second, gaps = plan_head(
                agents, uncontrolled, fractions,
                state[b], s[b], offset[b], front, is_car, active[b], width, route[b],
                entered[b], max_speed, brake_limit, curvature, speed_limit, enter_s,
                route_light, stop_s, across, light_state[b], ends, cycle, light_offset,
                times[b], cw_centre, cw_axis, cw_half, car_enter, walk_crosswalk, walk_enter,
                turning, offs, radius, reach, path_c64[b], path_dir[b], decay, hold_wild,
                ints, floats, look, yield_to_pedestrians, defensive,
            )  # fmt: skip
        else:  # nothing to plan (its targets stay 0)
            targets = np.empty((0, n_cand))
            s_proj = np.empty((0, n_cand, 1))
            allowed = np.empty((0, n_cand), np.bool_)
            first, second = np.empty(0, np.int64), np.empty(0, np.int64)
            gaps = np.empty((0, 9), np.complex64)
        heads.append((agents, targets, s_proj, allowed, first, second))
        chunks.append(gaps)
        starts[j + 1] = starts[j] + len(gaps)
    stacked = np.empty((starts[-1], 9), np.complex64)
    for j in range(len(due)):
        stacked[starts[j] : starts[j + 1]] = chunks[j]
    return heads, stacked, starts


@kernel
def plan_tail_worlds(
    due, heads, gap_abs, starts,
    state, s, offset, front, is_car, route, enter_s,
    offs, radius, reach, path_c64, path_dir, inv_spacing, margin, pedestrian_margin, out,
):  # fmt: skip  # pragma: no cover (compiled)
    """`plan_tail` of each due world from `plan_head_worlds`' results
    (`gap_abs`: numpy's abs of its stacked gaps): row `b` of `out` (B, N) becomes world
    `b`'s targets (0 for its inactive agents). Returns the position in `due` of the first
    world whose CSP had no solution, or -1."""
    for j in range(len(due)):
        b = due[j]
        out[b, :] = 0.0
        agents, targets, s_proj, allowed, first, second = heads[j]
        if not len(agents):
            continue
        solved = plan_tail(
            agents, targets, s_proj, allowed, first, second, gap_abs[starts[j] : starts[j + 1]],
            state[b], s[b], offset[b], front, is_car, route[b], enter_s, offs, radius, reach,
            path_c64[b], path_dir[b], inv_spacing, margin, pedestrian_margin, out[b],
        )  # fmt: skip
        if not solved:
            return j
    return -1
