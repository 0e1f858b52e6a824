"""Compiled inner loops of the driving supervisor (numba): velocity planner and PID.

The planner's pairwise check visits every pair of agents, every pair of candidate speeds and
every projected time, and stops at the first time the two footprints come too close. In numpy
that is a few large temporary arrays per plan and no early exit; compiled, it is a loop that
touches only what it needs. The PID loops are a few dozen scalar operations per agent, cheaper
compiled than as numpy calls on 16-element arrays. The arithmetic is the numpy version's,
operation for operation and in the same precision (float32 positions, float64 thresholds, no
fused multiply-add), except that atan2 is the C library's scalar function, which numpy's
vectorised one may differ from in the last bit on some CPUs
(`tests/tasks/fluids/supervisor/test_supervisor_kernels.py` keeps those references). The simulator's own
loops are in `fluids_bench.tasks.fluids.sim.kernels`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fluids_bench.core.compiled import callee, kernel


@njit(cache=True, nogil=True, inline="always")
def swept_box(px, py, now_x, now_y, bound, i):  # pragma: no cover (compiled)
    """Agent `i`'s swept box (lo_x, hi_x, lo_y, hi_y): every candidate, every projected time
    and its position now, grown by its bounding-circle radius `bound[i]` (m)."""
    x0, x1, y0, y1 = now_x[i], now_x[i], now_y[i], now_y[i]
    for a in range(px.shape[1]):
        for t in range(px.shape[2]):
            x0, x1 = min(x0, px[i, a, t]), max(x1, px[i, a, t])
            y0, y1 = min(y0, py[i, a, t]), max(y1, py[i, a, t])
    return x0 - bound[i], x1 + bound[i], y0 - bound[i], y1 + bound[i]


# The per-pair helpers are inlined into their callers by numba (inline="always"): no reference
# counting of their array arguments per call, and the callers' loops optimise across them. So
# are the small helpers that only kernels call, here and in the other kernel modules: a helper
# compiled on its own costs some 0.3 CPU-s of a cold start (its own module, machine code and
# Python wrappers), inlined only its typing at each call. Not a helper with inlined helpers of
# its own that is itself inlined at several places: numba copies an inlined function's IR once
# per block of it, which made `defensive_kernels._give_way` alone take 18 CPU-s.
@njit(cache=True, nogil=True, inline="always")
def too_close(px, py, ux, uy, offs, i, a, j, b, reach2, thresh2):  # pragma: no cover (compiled)
    """Whether agent `i` at candidate `a` and agent `j` at candidate `b` come too close
    at some projected time: bounding circles nearer than `sqrt(reach2)` (broad phase), then
    the nearest pair of footprint circles nearer than `sqrt(thresh2)` (float32 positions)."""
    n_t = px.shape[2]
    # few times pass the broad phase: find the first and the last that do without a branch
    # per time (the loop vectorises), then visit only the times between them
    lo, hi = n_t, -1
    for t in range(n_t):
        dx = px[i, a, t] - px[j, b, t]
        dy = py[i, a, t] - py[j, b, t]
        near = dx * dx + dy * dy < reach2
        lo, hi = min(lo, t if near else n_t), max(hi, t if near else -1)
    for t in range(lo, hi + 1):
        dx = px[i, a, t] - px[j, b, t]
        dy = py[i, a, t] - py[j, b, t]
        if not dx * dx + dy * dy < reach2:
            continue
        # the nearest pair of circles is too close iff any pair is: stop at the first
        for ci in range(3):
            xi = px[i, a, t] + offs[i, ci] * ux[i, a, t]
            yi = py[i, a, t] + offs[i, ci] * uy[i, a, t]
            for cj in range(3):
                ex = xi - (px[j, b, t] + offs[j, cj] * ux[j, b, t])
                ey = yi - (py[j, b, t] + offs[j, cj] * uy[j, b, t])
                if ex * ex + ey * ey < thresh2:
                    return True
    return False


@njit(cache=True, nogil=True, inline="always")
def path_samples_into(
    path_c64, path_dir, agents, proj, rows, inv_spacing, px, py, ux, uy
):  # pragma: no cover (compiled)
    """Points and unit tangents (float32) of each agent in `rows` (positions in `agents`) at
    the arc lengths `proj` (A, K, T), written into px, py, ux, uy (as World.path_samples)."""
    width = path_c64.shape[1]
    for a in rows:
        agent = agents[a]
        for k in range(proj.shape[1]):
            for t in range(proj.shape[2]):
                i = np.int64(np.rint(proj[a, k, t] * inv_spacing))
                i = min(max(i, 0), width - 1)
                px[a, k, t], py[a, k, t] = path_c64[agent, i].real, path_c64[agent, i].imag
                ux[a, k, t], uy[a, k, t] = path_dir[agent, i].real, path_dir[agent, i].imag


@callee
def path_samples(path_c64, path_dir, agents, proj, rows, inv_spacing):  # pragma: no cover
    """(px, py, ux, uy): `path_samples_into` into new arrays, whose rows not in
    `rows` are left unset (no caller reads them; zeroing them cost more than sampling)."""
    shape = proj.shape
    px, py = np.empty(shape, np.float32), np.empty(shape, np.float32)
    ux, uy = np.empty(shape, np.float32), np.empty(shape, np.float32)
    path_samples_into(path_c64, path_dir, agents, proj, rows, inv_spacing, px, py, ux, uy)
    return px, py, ux, uy


@callee
def swept_boxes(px, py, now_x, now_y, bound, rows):  # pragma: no cover (compiled)
    """(A, 4) `swept_box` of each agent in `rows` (zeros elsewhere)."""
    box = np.zeros((px.shape[0], 4))
    for a in rows:
        box[a, 0], box[a, 1], box[a, 2], box[a, 3] = swept_box(px, py, now_x, now_y, bound, a)
    return box


@njit(cache=True, nogil=True, inline="always")
def swept_boxes_of_candidates(cbox, now_x, now_y, bound, rows):  # pragma: no cover (compiled)
    """`swept_boxes` from the candidates' boxes (`candidate_boxes`): the same
    bounds, as min and max are exact, from K boxes instead of K·T points."""
    box = np.zeros((cbox.shape[0], 4))
    for a in rows:
        x0, x1, y0, y1 = now_x[a], now_x[a], now_y[a], now_y[a]
        for k in range(cbox.shape[1]):
            x0, x1 = min(x0, cbox[a, k, 0]), max(x1, cbox[a, k, 1])
            y0, y1 = min(y0, cbox[a, k, 2]), max(y1, cbox[a, k, 3])
        box[a, 0], box[a, 1] = x0 - bound[a], x1 + bound[a]
        box[a, 2], box[a, 3] = y0 - bound[a], y1 + bound[a]
    return box


@njit(cache=True, nogil=True, inline="always")
def boxes_apart(box, i, j):  # pragma: no cover (compiled)
    """The swept boxes of `i` and `j` do not overlap (the pair cannot conflict)."""
    return (
        box[i, 0] > box[j, 1]
        or box[j, 0] > box[i, 1]
        or (box[i, 2] > box[j, 3] or box[j, 2] > box[i, 3])
    )


# Boxes of float32 positions more than this multiple of the pair's summed reach apart cannot
# hold two points that pass too_close's float32 broad phase (whose rounding is ~1e-7 relative)
_APART = 1.001


@njit(cache=True, nogil=True, inline="always")
def candidate_boxes(px, py, rows):  # pragma: no cover (compiled)
    """(A, K, 4) box (lo_x, hi_x, lo_y, hi_y; m) of each candidate's projected positions, for
    the agents in `rows` (zeros elsewhere)."""
    box = np.zeros((px.shape[0], px.shape[1], 4))
    for a in rows:
        for k in range(px.shape[1]):
            x0, x1, y0, y1 = px[a, k, 0], px[a, k, 0], py[a, k, 0], py[a, k, 0]
            for t in range(1, px.shape[2]):
                x0, x1 = min(x0, px[a, k, t]), max(x1, px[a, k, t])
                y0, y1 = min(y0, py[a, k, t]), max(y1, py[a, k, t])
            box[a, k, 0], box[a, k, 1], box[a, k, 2], box[a, k, 3] = x0, x1, y0, y1
    return box


@njit(cache=True, nogil=True, inline="always")
def candidates_apart(cbox, i, a, j, b, reach):  # pragma: no cover (compiled)
    """Agent `i`'s candidate `a` and `j`'s candidate `b` stay more than `reach` (m,
    their summed bounding radii) times `_APART` apart on some axis: `too_close`
    would find no time that passes its broad phase, so it need not run."""
    r = reach * _APART
    return (
        cbox[i, a, 0] - cbox[j, b, 1] > r
        or cbox[j, b, 0] - cbox[i, a, 1] > r
        or cbox[i, a, 2] - cbox[j, b, 3] > r
        or cbox[j, b, 2] - cbox[i, a, 3] > r
    )


@callee
def projected_arc_lengths(
    s0, v0, targets, decay, steps, every, dt, max_accel, max_decel, gain
):  # pragma: no cover (compiled)
    """Arc lengths (A, K, T) travelled from `s0` (A,) at speed `v0` (A,) toward each target
    speed (A, K) under the PID's discrete speed law, sampled every `every` of `steps` steps.

    A saturated, linear phase of `n1` steps, then a geometric approach: `decay[n + steps]`
    is (1 - gain·dt)^n. Speeds are integrated with the trapezoid rule, as a cumulative sum.

    Each (agent, candidate) lane's speeds come first, phase by phase (no branch per step, and
    the approach reads `decay` in order); then the sums, time outer and lanes inner, so that
    the lanes' chains of dependent additions overlap. Each lane's arithmetic is unchanged.
    """
    n_agents, n_cand = targets.shape
    out = np.empty((n_agents, n_cand, (steps - every) // every + 1))
    n = n_agents * n_cand
    speed = np.empty((steps + 1, n))  # speed[m, q]: lane q's after m steps
    for a in range(n_agents):
        for k in range(n_cand):
            q = a * n_cand + k
            e0 = v0[a] - targets[a, k]
            sign = 1.0 if e0 > 0 else (-1.0 if e0 < 0 else 0.0)
            lim = max_accel if e0 < 0 else max_decel
            n1 = max(0.0, np.ceil((abs(e0) - lim / gain) / (lim * dt)))
            slope = sign * lim * dt
            e1 = e0 - slope * n1
            last = int(min(n1, float(steps)))  # the linear phase's last step (n1 is whole)
            speed[0, q] = v0[a]
            for m in range(1, last + 1):
                speed[m, q] = max(v0[a] - slope * float(m), 0.0)
            for m in range(last + 1, steps + 1):
                speed[m, q] = max(targets[a, k] + e1 * decay[m - last + steps], 0.0)
    travelled = np.zeros(n)
    for m in range(1, steps + 1):
        for q in range(n):
            travelled[q] += 0.5 * (speed[m - 1, q] + speed[m, q]) * dt
        if m % every == 0:
            for a in range(n_agents):
                for k in range(n_cand):
                    out[a, k, m // every - 1] = s0[a] + travelled[a * n_cand + k]
    return out


@kernel
def lookahead_points(
    path_z, s, state, path_len, min_ahead, ahead_time, spacing
):  # pragma: no cover
    """The point (N, 2) of each agent's path (`path_z` (N, M), x + iy) a look-ahead distance
    ahead of its progress `s`: max(min_ahead, ahead_time · speed) metres (speed: `state`'s
    last column), capped at the path's end."""
    out = np.empty((len(s), 2))
    last = path_z.shape[1] - 1
    for i in range(len(s)):
        ahead = max(min_ahead[i], ahead_time[i] * state[i, 3])
        k = np.rint(min(s[i] + ahead, path_len[i]) / spacing)
        k = min(max(int(k), 0), last)
        out[i, 0], out[i, 1] = path_z[i, k].real, path_z[i, k].imag
    return out


@kernel
def mark_off_route(
    lateral, heading_error, active, is_car, max_lateral, max_heading, out
):  # pragma: no cover (compiled)
    """Marks in `out` the active cars farther than `max_lateral` (m) from their paths or
    with a heading error above `max_heading` (rad); returns how many (an int boxes faster
    than an index array, and nearly every step has none)."""
    count = 0
    for i in range(lateral.shape[0]):
        out[i] = (
            active[i]
            and is_car[i]
            and (abs(lateral[i]) > max_lateral or abs(heading_error[i]) > max_heading)
        )
        count += out[i]
    return count


@njit(cache=True, nogil=True, inline="always")
def pid_controls_into(
    state, aim, is_car, target_speed, steer_prev, steer_int, speed_int, dt, gains, limits, gain,
    low, high, out, err, integ, v_int,
):  # fmt: skip  # pragma: no cover (compiled)
    """Controls (N, 2) of the two PID loops into `out`, and their new memory into `err`,
    `integ` and `v_int` (N,: error, steering and speed integrators).

    gains: steering kp, ki, kd/dt, speed kp, ki; limits: max steer (rad), max decel, max accel
    (m/s²); gain, low, high (N,): acceleration to actuator units, and the actuator's range.
    """
    steer_kp, steer_ki, steer_kd_dt, speed_kp, speed_ki = gains
    max_steer, max_decel, max_accel = limits
    for i in range(len(state)):
        desired = np.arctan2(aim[i, 1] - state[i, 1], aim[i, 0] - state[i, 0])
        e = (desired - state[i, 2] + np.pi) % (2 * np.pi) - np.pi
        err[i], integ[i] = e, steer_int[i] + e * dt
        steer = steer_kp * e + steer_kd_dt * (e - steer_prev[i])
        if steer_ki:
            steer += steer_ki * integ[i]
        v_err = target_speed[i] - state[i, 3]
        v_int[i] = speed_int[i] + v_err * dt
        accel = speed_kp * v_err
        if speed_ki:
            accel += speed_ki * v_int[i]
        out[i, 0] = min(max(steer, -max_steer), max_steer) if is_car[i] else desired
        accel = min(max(accel, -max_decel), max_accel)
        out[i, 1] = min(max(accel * gain[i], low[i]), high[i])


@kernel
def pid_controls(
    state, aim, is_car, target_speed, steer_prev, steer_int, speed_int, dt, gains, limits, gain,
    low, high,
):  # fmt: skip  # pragma: no cover (compiled)
    """`pid_controls_into` new arrays: the controls and the loops' new memory."""
    n = len(state)
    out, err, integ, v_int = np.empty((n, 2)), np.empty(n), np.empty(n), np.empty(n)
    pid_controls_into(
        state, aim, is_car, target_speed, steer_prev, steer_int, speed_int, dt, gains, limits,
        gain, low, high, out, err, integ, v_int,
    )  # fmt: skip
    return out, err, integ, v_int


@kernel
def pid_follow(
    path_z, s, path_len, min_ahead, ahead_time, spacing, state, is_car, target_speed, steer_prev,
    steer_int, speed_int, dt, gains, limits, gain, low, high,
):  # fmt: skip  # pragma: no cover (compiled)
    """`pid_controls` toward each agent's `lookahead_points`, in one call."""
    aim = lookahead_points(path_z, s, state, path_len, min_ahead, ahead_time, spacing)
    return pid_controls(
        state, aim, is_car, target_speed, steer_prev, steer_int, speed_int, dt, gains, limits,
        gain, low, high,
    )  # fmt: skip


@kernel
def pid_follow_into(
    path_z, s, path_len, min_ahead, ahead_time, spacing, state, is_car, target_speed, steer_prev,
    steer_int, speed_int, dt, gains, limits, gain, low, high, out, memory,
):  # fmt: skip  # pragma: no cover (compiled)
    """`pid_follow` into `out` (N, 2) and `memory` (3, N: the rows of its memory),
    which saves the caller new arrays."""
    aim = lookahead_points(path_z, s, state, path_len, min_ahead, ahead_time, spacing)
    pid_controls_into(
        state, aim, is_car, target_speed, steer_prev, steer_int, speed_int, dt, gains, limits,
        gain, low, high, out, memory[0], memory[1], memory[2],
    )  # fmt: skip


@callee
def hold_then_brake_into(
    out, rows, s0, v0, targets, hold, steps, every, dt, max_accel, decel, gain
):  # pragma: no cover (compiled)
    """The rows `rows` of `hold_then_brake` (its arguments, (A, ...)), written into
    `out` (A, K, T); the other rows are left alone.

    Each candidate of each row is its own chain of dependent operations. All of them are
    stepped side by side, time outer and one flat loop over the (row, candidate) lanes inner,
    which vectorises and keeps the CPU busy; each lane's arithmetic is unchanged."""
    n_cand = targets.shape[1]
    n = len(rows) * n_cand
    v, travelled, goal = np.empty(n), np.zeros(n), np.empty(n)
    until, lane_decel, lane_gain = np.empty(n, np.int64), np.empty(n), np.empty(n)
    for r in range(len(rows)):
        a = rows[r]
        for k in range(n_cand):
            q = r * n_cand + k
            v[q], goal[q], until[q] = v0[a], targets[a, k], hold[a, k]
            lane_decel[q], lane_gain[q] = decel[a], gain[a]
    for m in range(1, steps + 1):
        for q in range(n):
            target = goal[q] if m <= until[q] else 0.0
            dv = lane_gain[q] * (target - v[q])
            dv = min(max(dv, -lane_decel[q]), max_accel)
            nv = max(v[q] + dv * dt, 0.0)
            travelled[q] += 0.5 * (v[q] + nv) * dt
            v[q] = nv
        if m % every == 0:
            for r in range(len(rows)):
                for k in range(n_cand):
                    out[rows[r], k, m // every - 1] = s0[rows[r]] + travelled[r * n_cand + k]


@kernel
def hold_then_brake(
    s0, v0, targets, hold, steps, every, dt, max_accel, decel, gain
):  # pragma: no cover (compiled)
    """Arc lengths (A, K, T) of agents that track `targets` (A, K) for `hold` (A, K) steps
    and then brake to a stop, sampled every `every` of `steps` steps (the defensive check's
    projections; stepped, not in closed form, because the target changes mid-way).

    The speed law is the PID's, v += clip(gain · (target − v), −decel, max_accel) · dt, floored
    at 0, with per-agent `decel` (A,) and `gain` (A,): a supervised agent brakes as its
    controller does; an uncontrolled one with `gain = 1 / dt` and its physical limit, i.e.
    as hard as it can. Speeds are integrated with the trapezoid rule, as in
    `projected_arc_lengths`.
    """
    n_agents, n_cand = targets.shape
    out = np.empty((n_agents, n_cand, (steps - every) // every + 1))
    hold_then_brake_into(
        out, np.arange(n_agents), s0, v0, targets, hold, steps, every, dt, max_accel, decel, gain
    )
    return out


@njit(cache=True, nogil=True, inline="always")
def positions_now(agents, state, route, enter_s, is_car, s, offset, front):  # pragma: no cover
    """Where the planned agents are now (float32 x, y) and which are walkers on their crossing
    (front past their route's `enter_s`), whom cars may pass with a smaller clearance."""
    n_agents = len(agents)
    now_x, now_y = np.empty(n_agents, np.float32), np.empty(n_agents, np.float32)
    crossing = np.zeros(n_agents, np.bool_)
    for a in range(n_agents):
        ag = agents[a]
        now_x[a], now_y[a] = np.float32(state[ag, 0]), np.float32(state[ag, 1])
        r = route[ag] if route[ag] >= 0 else route[ag] + len(enter_s)
        crossing[a] = not is_car[ag] and s[ag] + offset[ag] + front[ag] >= enter_s[r]
    return now_x, now_y, crossing


@callee
def plan_conflicts(
    agents, s_proj, first, second, d_now,
    state, s, offset, front, is_car, route, enter_s,
    offs, radius, reach, path_c64, path_dir, inv_spacing, margin, pedestrian_margin,
):  # fmt: skip  # pragma: no cover (compiled)
    """The CSP's binary constraints: pairs (P', 2) of positions in `agents` and their
    conflict[p, a, b] (P', K, K), only the pairs with some conflict once both braking (0, 0)
    is allowed (so the CSP stays feasible).

    first, second (P,): the candidate pairs (positions in `agents`, each with a car);
    d_now (P,) float32: the distance now between their nearest footprint circles (m; computed
    by the caller with numpy's complex arithmetic). Projections `s_proj` (A, K, T) are
    sampled on the agents' paths (complex64 points and tangents, `inv_spacing` samples per
    metre). A pair already closer than its clearance conflicts only where it gets closer
    still: the clearance is `min(clearance, d_now - 0.05)`, floored at 0. The clearance is
    the footprint circles' radii plus `margin` (m), or `pedestrian_margin` once a walker of
    the pair is on its crossing (its front past its route's `enter_s`). World arrays (N, ...)
    as `defensive_kernels.defensive_forbid` takes them.
    """
    n_agents, n_cand = s_proj.shape[0], s_proj.shape[1]
    rows = np.arange(n_agents)
    px, py, ux, uy = path_samples(path_c64, path_dir, agents, s_proj, rows, inv_spacing)
    now_x, now_y, crossing = positions_now(agents, state, route, enter_s, is_car, s, offset, front)
    offs_a, radius_a, bound = offs[agents], radius[agents], reach[agents]
    cbox = candidate_boxes(px, py, rows)
    box = swept_boxes_of_candidates(cbox, now_x, now_y, bound, rows)
    table = np.zeros((len(first), n_cand, n_cand), dtype=np.bool_)
    keep = np.zeros(len(first), dtype=np.bool_)
    for p in range(len(first)):
        i, j = first[p], second[p]
        if boxes_apart(box, i, j):
            continue
        m = pedestrian_margin if crossing[i] or crossing[j] else margin
        # float32 as numpy computes d_now - 0.05 for a float32 array
        thresh = max(min(radius_a[i] + radius_a[j] + m, d_now[p] - np.float32(0.05)), 0.0)
        reach = bound[i] + bound[j]
        reach2 = np.float32(reach * reach)
        for a in range(n_cand):
            for b in range(n_cand):
                if a == 0 and b == 0:
                    continue  # both braking is always allowed
                if candidates_apart(cbox, i, a, j, b, reach):
                    continue
                hit = too_close(px, py, ux, uy, offs_a, i, a, j, b, reach2, thresh * thresh)
                table[p, a, b] = hit
                keep[p] |= hit
    count = 0
    for p in range(len(first)):
        count += keep[p]
    out, kept = np.empty((count, 2), dtype=np.int64), np.empty((count, n_cand, n_cand), np.bool_)
    q = 0
    for p in range(len(first)):
        if keep[p]:
            out[q, 0], out[q, 1] = first[p], second[p]
            for a in range(n_cand):
                for b in range(n_cand):
                    kept[q, a, b] = table[p, a, b]
            q += 1
    return out, kept


@callee
def allowed_speeds(
    agents, s, offset, route, is_car, max_speed, curvature, speed_limit, look, lateral_accel,
    spacing,
):  # fmt: skip  # pragma: no cover (compiled)
    """Speed (m/s) each of `agents` may drive at now: its maximum, its lane's limit at its
    path sample, and the sharpest curvature of the next `look` samples of its route (at
    `lateral_accel` m/s²); a walker's maximum."""
    out = np.empty(len(agents))
    last = curvature.shape[1] - 1
    for a in range(len(agents)):
        ag = agents[a]
        r = route[ag] if route[ag] >= 0 else route[ag] + curvature.shape[0]
        k0 = np.int64(np.rint((s[ag] + offset[ag]) / spacing))
        kappa = -np.inf
        for m in range(look):
            kappa = max(kappa, curvature[r, min(max(k0 + m, 0), last)])
        limit = speed_limit[r, min(max(k0, 0), last)]
        curve = np.sqrt(lateral_accel / max(kappa, 1e-6))
        out[a] = min(max_speed[ag], min(limit, curve)) if is_car[ag] else max_speed[ag]
    return out


@callee
def circle_gaps(agents, state, is_car, offs):  # pragma: no cover (compiled)
    """The planner's candidate pairs and how far apart their footprint circles are now.

    Returns (first, second) (P,): the pairs of positions i < j in `agents` with a car, in
    row order; and gaps (P, 9) complex64: each circle of `first` minus each of `second`
    (circle centres at `offs` (N, 3) float32 m along the heading, in complex64 as numpy
    computes `pos + offs * exp(1j·θ)`). Their lengths are left to numpy's complex abs, which
    the planner's reference uses (its vector loop and the C library's hypotf differ in the
    last bit).
    """
    n = len(agents)
    now = np.empty((n, 3), np.complex64)
    for a in range(n):
        ag = agents[a]
        heading = np.complex64(np.exp(1j * state[ag, 2]))
        x, y = np.float32(state[ag, 0]), np.float32(state[ag, 1])
        for c in range(3):
            now[a, c] = np.complex64(
                complex(x + offs[ag, c] * heading.real, y + offs[ag, c] * heading.imag)
            )
    count = 0
    for i in range(n):
        for j in range(i + 1, n):
            count += is_car[agents[i]] or is_car[agents[j]]
    first, second = np.empty(count, np.int64), np.empty(count, np.int64)
    gaps = np.empty((count, 9), np.complex64)
    p = 0
    for i in range(n):
        for j in range(i + 1, n):
            if not (is_car[agents[i]] or is_car[agents[j]]):
                continue
            first[p], second[p] = i, j
            for ci in range(3):
                for cj in range(3):
                    gaps[p, 3 * ci + cj] = now[i, ci] - now[j, cj]
            p += 1
    return first, second, gaps
