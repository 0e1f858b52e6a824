"""The velocity planner's defensive constraints in one compiled call (numba).

`VelocityPlanner.defensive_domains` prunes supervised agents' candidate speeds against
agents it does not control: the pairwise check against each uncontrolled agent braking, the
supervised followers of a leader that may have to brake at once, and giving way to an
uncontrolled agent with the right of way. As numpy it was some 60 array calls per plan on a
dozen agents; here it is one call that walks the pairs, projects only the agents a check
needs and stops at the first conflict that settles a candidate.

Pure function over arrays (agents' state, paths, route tables, the plan's candidates) with no
Python objects, so a batch of worlds can be walked the same way. The arithmetic is the numpy
formulation's, operation for operation (float64 projections, float32 path samples as in
`World.path_samples`, no fused multiply-add); the relative position of two agents uses
the C library's scalar sin/cos and plain complex multiplication, which numpy's vectorised loops
may differ from in the last bit on some CPUs, and it only feeds thresholds (ahead or behind,
aligned or not). `tests/tasks/fluids/supervisor/defensive_reference.py` keeps the numpy
formulation and `test_defensive_kernel.py` compares the two.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fluids_bench.core.compiled import callee
from fluids_bench.tasks.fluids.sim.dynamics import wrap_angle
from fluids_bench.tasks.fluids.supervisor.kernels import (
    boxes_apart,
    hold_then_brake_into,
    path_samples,
    positions_now,
    swept_boxes,
    too_close,
)


@callee
def _relative(state, f, ld):  # pragma: no cover (compiled)
    """Agent `ld`'s position in agent `f`'s frame (along, across; m) and whether the two
    head within 45° of each other (world indices)."""
    c, s = math.cos(state[f, 2]), -math.sin(state[f, 2])
    along, across = _in_frame(state, f, ld, c, s)
    return along, across, _aligned(state, f, ld)


@njit(cache=True, nogil=True, inline="always")
def _in_frame(state, f, ld, c, s):  # pragma: no cover (compiled)
    """Agent `ld`'s position in agent `f`'s frame (along, across; m); `c`, `s`: the
    cosine and minus the sine of f's heading (world indices)."""
    dx, dy = state[ld, 0] - state[f, 0], state[ld, 1] - state[f, 1]
    return dx * c - dy * s, dx * s + dy * c


@njit(cache=True, nogil=True, inline="always")
def _aligned(state, f, ld):  # pragma: no cover (compiled)
    """Agents `f` and `ld` head within 45° of each other (world indices)."""
    return abs(wrap_angle(state[ld, 2] - state[f, 2])) < math.pi / 4


@callee
def _mark_conflicts(samples, offs, box, i, j, of_second, reach2, thresh2, out):  # pragma: no cover
    """For each candidate c with `out[c]` False, set it where agent `i` at c (agent `j`
    if `of_second`: conflict[p, :, c].any()) comes too close to the other at any of its
    candidates. One call per pair (`too_close`, called per candidate pair, is inlined into
    it: a call of a compiled helper increments and decrements an atomic reference count per
    array it takes, which per candidate took a quarter of the kernel's time). Not inlined
    itself: numba copies an inlined function's IR once per block of it, so inlining this
    (with `too_close` inside) into `_mark_both_ways` and that into `_give_way` took 18 of
    the planner's 60 CPU-s of compiling."""
    if boxes_apart(box, i, j):
        return
    px, py, ux, uy = samples
    n_cand = px.shape[1]
    for c in range(n_cand):
        if out[c]:
            continue
        for d in range(n_cand):
            a, b = (d, c) if of_second else (c, d)
            if too_close(px, py, ux, uy, offs, i, a, j, b, reach2, thresh2):
                out[c] = True
                break


@njit(cache=True, nogil=True, inline="always")
def _mark_both_ways(
    s_stop, box_stop, s_go, box_go, offs, t, w, reach2, thresh2, out, hit_go
):  # pragma: no cover (compiled)
    """Set `out[k]` (where False) for each candidate k at which agent `t` comes too close
    to `w` both in the stop scenario and in the go one (any of w's candidates each);
    `hit_go` (K,) is scratch."""
    row = out.copy()
    _mark_conflicts(s_stop, offs, box_stop, t, w, np.bool_(False), reach2, thresh2, out)
    for k in range(len(out)):
        hit_go[k] = row[k] or not out[k]  # settled already, or clear when stopping
    _mark_conflicts(s_go, offs, box_go, t, w, np.bool_(False), reach2, thresh2, hit_go)
    for k in range(len(out)):
        out[k] = row[k] or (out[k] and hit_go[k])


@njit(cache=True, nogil=True, inline="always")
def _pair_limits(radius, bound, crossing, i, j, margin, ped_margin, contact):  # pragma: no cover
    """Squared broad-phase reach (float32) and squared clearance (m²) of positions i, j: the
    footprints' own with `contact`, else plus the margin (the smaller one once a walker of
    the pair is on its crossing). Callers pass `contact` as `np.bool_`, not a literal
    `True`/`False`, which numba would compile a second time for."""
    m = 0.0 if contact else (ped_margin if crossing[i] or crossing[j] else margin)
    clearance = radius[i] + radius[j] + m
    return np.float32((bound[i] + bound[j]) * (bound[i] + bound[j])), clearance * clearance


@njit(cache=True, nogil=True, inline="always")
def _clear_row_if_all(forbid, a):  # pragma: no cover (compiled)
    """Nothing is forbidden to `a` when everything would be (no candidate helps)."""
    for k in range(forbid.shape[1]):
        if not forbid[a, k]:
            return
    for k in range(forbid.shape[1]):
        forbid[a, k] = False


@callee
def defensive_forbid(
    agents, wild, targets, hold_lines,
    state, s, offset, front, is_car, entered, route, max_speed, brake_limit,
    offs, radius, reach, path_c64, path_dir,
    enter_s, across, curvature, speed_limit,
    fractions, hold_wild, ints, floats,
):  # fmt: skip  # pragma: no cover (compiled)
    """forbid[a, k] (A, K): supervised agent `a`'s candidate k could run into an uncontrolled
    one (`VelocityPlanner.defensive_domains`, which documents the rules).

    agents (A,): world indices of the planned agents; wild (A,): uncontrolled; targets (A, K)
    candidate speeds (m/s); hold_lines (A,): route arc lengths of the stop lines held (m, inf:
    none). World arrays (N, ...): state, s, offset, front, is_car, entered, route, max_speed,
    brake_limit (m/s², hardest braking), footprint circles offs (float32) and radius, bounding
    reach (m), paths as complex64 points and tangents. Route tables: enter_s (R,), across
    (R, R) (turns across the other's path), curvature and speed_limit (R, M). fractions (K,)
    of the allowed speed; hold_wild (K,): steps an uncontrolled agent holds its speed in each
    scenario. ints: period, steps of the plan's horizon, steps of the give-way horizon,
    sample_every, look-ahead samples of the give-way curve speed. floats: dt, max_accel,
    max_decel, speed_gain, margin, pedestrian_margin, lateral_accel, path spacing (m),
    stationary speed (m/s).
    """
    period, steps, every = ints[0], ints[1], ints[3]
    dt, max_accel, max_decel, gain = floats[0], floats[1], floats[2], floats[3]
    margin, ped_margin = floats[4], floats[5]
    inv_spacing = 1.0 / floats[7]
    n_agents, n_cand = targets.shape
    forbid = np.zeros((n_agents, n_cand), dtype=np.bool_)
    # pairs of one supervised and one uncontrolled agent, with a car, where the uncontrolled one
    # does not follow the supervised one (a rear-end is the follower's fault)
    first = np.empty(n_agents * (n_agents - 1) // 2, np.int64)
    second = np.empty_like(first)
    n_pairs = 0
    for i in range(n_agents):
        for j in range(i + 1, n_agents):
            if wild[i] == wild[j] or not (is_car[agents[i]] or is_car[agents[j]]):
                continue
            f, ld = (agents[i], agents[j]) if wild[i] else (agents[j], agents[i])
            along, _, aligned = _relative(state, f, ld)
            if not (aligned and along > 0):
                first[n_pairs], second[n_pairs] = i, j
                n_pairs += 1
    if n_pairs == 0:
        return forbid
    first, second = first[:n_pairs], second[:n_pairs]
    now_x, now_y, crossing = positions_now(agents, state, route, enter_s, is_car, s, offset, front)
    offs_a, radius_a, bound = offs[agents], radius[agents], reach[agents]
    # the uncontrolled agent brakes as hard as it can now or a few steps from now; the
    # supervised one holds its candidate until the next plan, then brakes
    s0, v0 = np.empty(n_agents), np.empty(n_agents)
    goal, hold = np.empty((n_agents, n_cand)), np.empty((n_agents, n_cand), np.int64)
    decel, gains = np.empty(n_agents), np.empty(n_agents)
    for a in range(n_agents):
        ag = agents[a]
        s0[a], v0[a] = s[ag], state[ag, 3]
        if wild[a]:
            decel[a], gains[a] = brake_limit[ag], 1.0 / dt
            for k in range(n_cand):
                goal[a, k], hold[a, k] = v0[a], hold_wild[k]
        else:
            decel[a], gains[a] = max_decel, gain
            for k in range(n_cand):
                goal[a, k], hold[a, k] = targets[a, k], period
    all_rows = np.arange(n_agents)
    s_def = np.empty((n_agents, n_cand, (steps - every) // every + 1))
    hold_then_brake_into(
        s_def, all_rows, s0, v0, goal, hold, steps, every, dt, max_accel, decel, gains
    )
    samples = path_samples(path_c64, path_dir, agents, s_def, all_rows, inv_spacing)
    box = swept_boxes(samples[0], samples[1], now_x, now_y, bound, all_rows)
    for p in range(len(first)):
        i, j = first[p], second[p]
        reach2, thresh2 = _pair_limits(
            radius_a, bound, crossing, i, j, margin, ped_margin, np.bool_(False)
        )
        row = forbid[j] if wild[i] else forbid[i]  # the supervised agent's
        _mark_conflicts(samples, offs_a, box, i, j, wild[i], reach2, thresh2, row)
    follow = _follow_supervised(
        agents, wild, state, s0, v0, is_car, s_def, path_c64, path_dir, inv_spacing, now_x,
        now_y, bound, offs_a, radius_a, crossing, ints, floats,
    )  # fmt: skip
    give_way = _give_way(
        agents, wild, targets, hold_lines, first, second, s0, v0, s, offset, front, is_car,
        entered, route, max_speed, across, curvature, speed_limit, fractions, path_c64,
        path_dir, now_x, now_y, bound, offs_a, radius_a, crossing, ints, floats,
    )  # fmt: skip
    for a in range(n_agents):
        for k in range(n_cand):
            forbid[a, k] |= follow[a, k]
        # braking now is unsafe both ways while going on clears the path: it goes on
        if forbid[a, 0] and give_way[a, 0]:
            for k in range(n_cand):
                forbid[a, k] = False
        for k in range(n_cand):
            forbid[a, k] |= give_way[a, k]
        forbid[a, 0] = False
    return forbid


@callee
def _follow_supervised(
    agents, wild, state, s0, v0, is_car, s_def, path_c64, path_dir, inv_spacing, now_x,
    now_y, bound, offs_a, radius_a, crossing, ints, floats,
):  # fmt: skip  # pragma: no cover (compiled)
    """forbid[a, k]: supervised follower a's candidate k (held until the next plan, then
    braking: `s_def`) runs into the supervised car ahead of it in its lane braking now
    (s0, v0: the planned agents' arc lengths and speeds)."""
    every = ints[3]
    dt, max_accel, max_decel, gain = floats[0], floats[1], floats[2], floats[3]
    n_agents, n_cand = s_def.shape[0], s_def.shape[1]
    forbid = np.zeros((n_agents, n_cand), dtype=np.bool_)
    idx, n_idx = np.empty(n_agents, np.int64), 0
    for a in range(n_agents):
        if is_car[agents[a]] and not wild[a]:
            idx[n_idx] = a
            n_idx += 1
    idx = idx[:n_idx]
    if len(idx) < 2:
        return forbid
    fs = np.empty(len(idx) * len(idx), np.int64)
    ls = np.empty_like(fs)
    n_pairs = 0
    for f in idx:
        # each follower's frame once (not per pair), and the heading test (a floored
        # modulo) only for the few cars right ahead of it
        c, sn = math.cos(state[agents[f], 2]), -math.sin(state[agents[f], 2])
        for ld in idx:
            if f == ld:
                continue
            along, across = _in_frame(state, agents[f], agents[ld], c, sn)
            if along > 0 and abs(across) < 2.0 and _aligned(state, agents[f], agents[ld]):
                fs[n_pairs], ls[n_pairs] = f, ld
                n_pairs += 1
    if n_pairs == 0:
        return forbid
    fs, ls = fs[:n_pairs], ls[:n_pairs]
    involved = np.zeros(n_agents, np.bool_)
    leader = np.zeros(n_agents, np.bool_)
    for p in range(len(fs)):
        involved[fs[p]] = involved[ls[p]] = leader[ls[p]] = True
    rows = involved.nonzero()[0]
    brake = s_def.copy()  # followers hold their candidate until the next plan, then brake
    hold_then_brake_into(  # leaders brake now
        brake, leader.nonzero()[0], s0, v0, np.zeros((n_agents, n_cand)),
        np.zeros((n_agents, n_cand), np.int64), s_def.shape[2] * every, every, dt, max_accel,
        np.full(n_agents, max_decel), np.full(n_agents, gain),
    )  # fmt: skip
    samples = path_samples(path_c64, path_dir, agents, brake, rows, inv_spacing)
    box = swept_boxes(samples[0], samples[1], now_x, now_y, bound, rows)
    px, py, ux, uy = samples
    for p in range(len(fs)):
        f, ld = fs[p], ls[p]
        reach2, thresh2 = _pair_limits(
            radius_a, bound, crossing, f, ld, floats[4], floats[5], np.bool_(False)
        )
        if boxes_apart(box, f, ld):
            continue
        for k in range(n_cand):
            if not forbid[f, k]:  # against the leader's candidate 0 (all brake now alike)
                forbid[f, k] = too_close(px, py, ux, uy, offs_a, f, k, ld, 0, reach2, thresh2)
    for a in range(n_agents):
        _clear_row_if_all(forbid, a)  # cannot help any more
    return forbid


@callee
def _slowest_ahead(ag, s, offset, route, is_car, max_speed, curvature, speed_limit, look,
                   lateral_accel, spacing):  # fmt: skip  # pragma: no cover (compiled)
    """The lowest speed agent `ag` is allowed over the next `look` path samples of its
    route (curves and limits; m/s), inf for a walker."""
    if not is_car[ag]:
        return np.inf
    r = route[ag] if route[ag] >= 0 else route[ag] + curvature.shape[0]
    k0 = np.int64(np.rint((s[ag] + offset[ag]) / spacing))
    last = curvature.shape[1] - 1
    slowest = np.inf
    for m in range(look + 1):
        k = min(max(k0 + m, 0), last)
        curve = np.sqrt(lateral_accel / max(curvature[r, k], 1e-6))
        slowest = min(slowest, min(speed_limit[r, k], curve))
    return min(max_speed[ag], slowest)


@callee
def _give_way(
    agents, wild, targets, hold_lines, first, second, s0, v0, s, offset, front, is_car,
    entered, route, max_speed, across, curvature, speed_limit, fractions, path_c64,
    path_dir, now_x, now_y, bound, offs_a, radius_a, crossing, ints, floats,
):  # fmt: skip  # pragma: no cover (compiled)
    """forbid[a, k]: supervised agent a's candidate k could run into an uncontrolled agent
    with the right of way over it that keeps going (VelocityPlanner._give_way: it neither
    stops short of that agent's path nor clears it in time; s0, v0: the planned agents' arc
    lengths and speeds)."""
    period, gw_steps, every, look = ints[0], ints[2], ints[3], ints[4]
    dt, max_accel, max_decel, gain = floats[0], floats[1], floats[2], floats[3]
    margin, ped_margin, lateral_accel, spacing = floats[4], floats[5], floats[6], floats[7]
    stationary = floats[8]
    n_agents, n_cand = targets.shape
    n_routes = across.shape[0]
    forbid = np.zeros((n_agents, n_cand), dtype=np.bool_)
    ts, ws = np.empty(len(first), np.int64), np.empty(len(first), np.int64)
    n_pairs = 0
    for p in range(len(first)):
        t, w = (second[p], first[p]) if wild[first[p]] else (first[p], second[p])
        et, ew = entered[agents[t]], entered[agents[w]]
        rt, rw = route[agents[t]], route[agents[w]]
        rt, rw = (rt if rt >= 0 else rt + n_routes), (rw if rw >= 0 else rw + n_routes)
        if (ew >= 0 and (et < 0 or ew < et)) or across[rt, rw]:
            ts[n_pairs], ws[n_pairs] = t, w
            n_pairs += 1
    if n_pairs == 0:
        return forbid
    ts, ws = ts[:n_pairs], ws[:n_pairs]
    involved = np.zeros(n_agents, np.bool_)
    for p in range(len(ts)):
        involved[ts[p]] = involved[ws[p]] = True
    rows = involved.nonzero()[0]
    n_t = (gw_steps - every) // every + 1
    # the go scenario's goals; the stop one tracks the candidates with a period to spare
    goal, line = np.zeros((n_agents, n_cand)), np.empty(n_agents)
    for a in rows:
        ag, v = agents[a], v0[a]
        if wild[a]:
            # it keeps its speed or speeds up towards the fastest speed allowed to it (its
            # candidates' scenarios span the two); at rest, it stays
            faster = max(targets[a, n_cand - 1] - v, 0.0)
            for k in range(n_cand):
                goal[a, k] = v + faster * fractions[k] if v > stationary else 0.0
            continue
        slowest = _slowest_ahead(
            ag, s, offset, route, is_car, max_speed, curvature, speed_limit, look,
            lateral_accel, spacing,
        )  # fmt: skip
        line[a] = hold_lines[a] - offset[ag] - front[ag]  # it stops at its hold line
        # going on, it slows for the curves ahead (turning into a roundabout's ring)
        for k in range(n_cand):
            goal[a, k] = min(targets[a, k], slowest)
    decel, gains = np.full(n_agents, max_decel), np.full(n_agents, gain)
    stop = np.empty((n_agents, n_cand, n_t))  # only the rows are set, and read
    go = np.empty((n_agents, n_cand, n_t))
    hold_then_brake_into(
        go, rows, s0, v0, goal, np.full((n_agents, n_cand), gw_steps), gw_steps, every, dt,
        max_accel, decel, gains,
    )  # fmt: skip
    hold_then_brake_into(
        stop, rows[~wild[rows]], s0, v0, targets, np.full((n_agents, n_cand), 2 * period),
        gw_steps, every, dt, max_accel, decel, gains,
    )  # fmt: skip
    for a in rows:
        for k in range(n_cand):
            for t in range(n_t):
                if wild[a]:
                    stop[a, k, t] = go[a, k, t]
                else:
                    stop[a, k, t] = min(stop[a, k, t], line[a])
                    go[a, k, t] = min(go[a, k, t], line[a])
    inv_spacing = 1.0 / spacing
    s_stop = path_samples(path_c64, path_dir, agents, stop, rows, inv_spacing)
    s_go = path_samples(path_c64, path_dir, agents, go, rows, inv_spacing)
    box_stop = swept_boxes(s_stop[0], s_stop[1], now_x, now_y, bound, rows)
    box_go = swept_boxes(s_go[0], s_go[1], now_x, now_y, bound, rows)
    hit_go = np.empty(n_cand, np.bool_)
    for p in range(len(ts)):
        t, w = ts[p], ws[p]
        reach2, thresh2 = _pair_limits(
            radius_a, bound, crossing, t, w, margin, ped_margin, np.bool_(False)
        )
        _mark_both_ways(
            s_stop, box_stop, s_go, box_go, offs_a, t, w, reach2, thresh2, forbid[t], hit_go
        )
    stuck = np.zeros(n_agents, np.bool_)
    any_stuck = False
    for a in rows:
        stuck[a] = not wild[a]
        for k in range(n_cand):
            stuck[a] &= forbid[a, k]
        any_stuck |= stuck[a]
    if any_stuck:
        # no candidate keeps the full clearance both ways (a close pass counts, and a merge
        # is close): keep the candidates that at least do not touch that agent either way
        touch = np.zeros((n_agents, n_cand), dtype=np.bool_)
        for p in range(len(ts)):
            t, w = ts[p], ws[p]
            if not stuck[t]:
                continue
            reach2, thresh2 = _pair_limits(
                radius_a, bound, crossing, t, w, margin, ped_margin, np.bool_(True)
            )
            _mark_both_ways(
                s_stop, box_stop, s_go, box_go, offs_a, t, w, reach2, thresh2, touch[t], hit_go
            )
        for a in rows:
            if stuck[a]:
                for k in range(n_cand):
                    forbid[a, k] = touch[a, k]
    for a in range(n_agents):
        _clear_row_if_all(forbid, a)  # no candidate helps: it is already in the way
    return forbid
