"""Compiled inner loops of the driving supervisor (numba): velocity planner and PID.

The planner's pairwise check visits every pair of agents, every pair of candidate speeds and
every projected time, and stops at the first time the two footprints come too close. In numpy
that is a few large temporary arrays per plan and no early exit; compiled, it is a loop that
touches only what it needs. The PID loops are a few dozen scalar operations per agent, cheaper
compiled than as numpy calls on 16-element arrays. The arithmetic is the numpy version's,
operation for operation and in the same precision (float32 positions, float64 thresholds, no
fused multiply-add), except that atan2 is the C library's scalar function, which numpy's
vectorised one may differ from in the last bit on some CPUs
(``tests/tasks/fluids/supervisor/test_supervisor_kernels.py`` keeps those references). The simulator's own
loops are in :mod:`fluids_bench.tasks.fluids.sim.kernels`.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def swept_box(px, py, now_x, now_y, bound, i):  # pragma: no cover (compiled)
    """Agent ``i``'s swept box (lo_x, hi_x, lo_y, hi_y): every candidate, every projected time
    and its position now, grown by its bounding-circle radius ``bound[i]`` (m)."""
    x0, x1, y0, y1 = now_x[i], now_x[i], now_y[i], now_y[i]
    for a in range(px.shape[1]):
        for t in range(px.shape[2]):
            x0, x1 = min(x0, px[i, a, t]), max(x1, px[i, a, t])
            y0, y1 = min(y0, py[i, a, t]), max(y1, py[i, a, t])
    return x0 - bound[i], x1 + bound[i], y0 - bound[i], y1 + bound[i]


@njit(cache=True, nogil=True)
def too_close(px, py, ux, uy, offs, i, a, j, b, reach2, thresh2):  # pragma: no cover (compiled)
    """Whether agent ``i`` at candidate ``a`` and agent ``j`` at candidate ``b`` come too close
    at some projected time: bounding circles nearer than ``sqrt(reach2)`` (broad phase), then
    the nearest pair of footprint circles nearer than ``sqrt(thresh2)`` (float32 positions)."""
    for t in range(px.shape[2]):
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


@njit(cache=True, nogil=True)
def conflict_tables(
    px, py, ux, uy, now_x, now_y, bound, offs, first, second, reach2, thresh2
):  # pragma: no cover (compiled)
    """conflict[p, a, b]: agents ``first[p]`` at candidate a and ``second[p]`` at candidate b
    come too close at some projected time.

    px, py, ux, uy: (A, K, T) float32 positions and unit tangents of the projections; now_x,
    now_y: (A,) float32 positions now; bound: (A,) bounding-circle radius (m); offs: (A, 3)
    float32 offsets of each agent's footprint circles along its heading; reach2: (P,) float32
    squared bounding-circle reach of each pair (broad phase); thresh2: (P,) float64 squared
    clearance between footprint circles (narrow phase). Pairs whose swept boxes (every
    candidate, every time, and now) do not overlap are skipped.
    """
    n_agents, n_cand = px.shape[0], px.shape[1]
    box = np.empty((n_agents, 4))
    for i in range(n_agents):
        box[i, 0], box[i, 1], box[i, 2], box[i, 3] = swept_box(px, py, now_x, now_y, bound, i)
    out = np.zeros((len(first), n_cand, n_cand), dtype=np.bool_)
    for p in range(len(first)):
        i, j = first[p], second[p]
        if box[i, 0] > box[j, 1] or box[j, 0] > box[i, 1]:
            continue
        if box[i, 2] > box[j, 3] or box[j, 2] > box[i, 3]:
            continue
        for a in range(n_cand):
            for b in range(n_cand):
                out[p, a, b] = too_close(px, py, ux, uy, offs, i, a, j, b, reach2[p], thresh2[p])
    return out


@njit(cache=True, nogil=True)
def projected_arc_lengths(
    s0, v0, targets, decay, steps, every, dt, max_accel, max_decel, gain
):  # pragma: no cover (compiled)
    """Arc lengths (A, K, T) travelled from ``s0`` (A,) at speed ``v0`` (A,) toward each target
    speed (A, K) under the PID's discrete speed law, sampled every ``every`` of ``steps`` steps.

    A saturated, linear phase of ``n1`` steps, then a geometric approach: ``decay[n + steps]``
    is (1 - gain·dt)^n. Speeds are integrated with the trapezoid rule, as a cumulative sum.
    """
    n_agents, n_cand = targets.shape
    out = np.empty((n_agents, n_cand, (steps - every) // every + 1))
    for a in range(n_agents):
        for k in range(n_cand):
            e0 = v0[a] - targets[a, k]
            sign = 1.0 if e0 > 0 else (-1.0 if e0 < 0 else 0.0)
            lim = max_accel if e0 < 0 else max_decel
            n1 = max(0.0, np.ceil((abs(e0) - lim / gain) / (lim * dt)))
            slope = sign * lim * dt
            e1 = e0 - slope * n1
            prev, travelled = v0[a], 0.0
            for m in range(1, steps + 1):
                n = float(m)
                v = (
                    v0[a] - slope * n
                    if n <= n1
                    else targets[a, k] + e1 * decay[int(n - n1) + steps]
                )
                v = max(v, 0.0)
                travelled += 0.5 * (prev + v) * dt
                prev = v
                if m % every == 0:
                    out[a, k, m // every - 1] = s0[a] + travelled
    return out


@njit(cache=True, nogil=True)
def lookahead_points(path, s, speed, path_len, min_ahead, ahead_time, spacing):  # pragma: no cover
    """The point (N, 2) of each agent's path (N, M, 2) a look-ahead distance ahead of its
    progress ``s``: max(min_ahead, ahead_time · speed) metres, capped at the path's end."""
    out = np.empty((len(s), 2))
    last = path.shape[1] - 1
    for i in range(len(s)):
        k = np.rint(min(s[i] + max(min_ahead[i], ahead_time[i] * speed[i]), path_len[i]) / spacing)
        k = min(max(int(k), 0), last)
        out[i, 0], out[i, 1] = path[i, k, 0], path[i, k, 1]
    return out


@njit(cache=True, nogil=True)
def pid_controls(
    state,
    aim,
    is_car,
    target_speed,
    steer_prev,
    steer_int,
    speed_int,
    dt,
    gains,
    limits,
    gain,
    low,
    high,
):  # pragma: no cover (compiled)
    """Controls (N, 2) of the two PID loops and their new memory (error, integrators).

    gains: steering kp, ki, kd/dt, speed kp, ki; limits: max steer (rad), max decel, max accel
    (m/s²); gain, low, high (N,): acceleration to actuator units, and the actuator's range.
    """
    steer_kp, steer_ki, steer_kd_dt, speed_kp, speed_ki = gains
    max_steer, max_decel, max_accel = limits
    n = len(state)
    out, err, integ, v_int = np.empty((n, 2)), np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
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
    return out, err, integ, v_int


@njit(cache=True, nogil=True)
def hold_then_brake_into(
    out, a, k, s0, v0, target, hold, steps, every, dt, max_accel, decel, gain
):  # pragma: no cover (compiled)
    """One row of :func:`hold_then_brake`, written into ``out[a, k]``: start at ``s0`` (m) and
    ``v0`` (m/s), track ``target`` for ``hold`` steps, then brake."""
    v, travelled = v0, 0.0
    for m in range(1, steps + 1):
        goal = target if m <= hold else 0.0
        dv = gain * (goal - v)
        dv = min(max(dv, -decel), max_accel)
        nv = max(v + dv * dt, 0.0)
        travelled += 0.5 * (v + nv) * dt
        v = nv
        if m % every == 0:
            out[a, k, m // every - 1] = s0 + travelled


@njit(cache=True, nogil=True)
def hold_then_brake(
    s0, v0, targets, hold, steps, every, dt, max_accel, decel, gain
):  # pragma: no cover (compiled)
    """Arc lengths (A, K, T) of agents that track ``targets`` (A, K) for ``hold`` (A, K) steps
    and then brake to a stop, sampled every ``every`` of ``steps`` steps (the defensive check's
    projections; stepped, not in closed form, because the target changes mid-way).

    The speed law is the PID's, v += clip(gain · (target − v), −decel, max_accel) · dt, floored
    at 0, with per-agent ``decel`` (A,) and ``gain`` (A,): a supervised agent brakes as its
    controller does; an uncontrolled one with ``gain = 1 / dt`` and its physical limit, i.e.
    as hard as it can. Speeds are integrated with the trapezoid rule, as in
    :func:`projected_arc_lengths`.
    """
    n_agents, n_cand = targets.shape
    out = np.empty((n_agents, n_cand, (steps - every) // every + 1))
    for a in range(n_agents):
        for k in range(n_cand):
            hold_then_brake_into(
                out, a, k, s0[a], v0[a], targets[a, k], hold[a, k], steps, every, dt,
                max_accel, decel[a], gain[a],
            )  # fmt: skip
    return out
