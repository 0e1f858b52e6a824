"""Compiled inner loops of the sensors (numba): the explicit observation and the quasi-LIDAR's
ray casting.

The explicit observation is a few scalar operations per agent plus a nearest-first sort; as
numpy calls on arrays of tens of elements it cost ~100 µs a step, compiled a few µs.

A quasi-LIDAR reading tests a few dozen rays against a dozen agents and a few dozen kerb
segments: a few thousand tiny ray-versus-shape tests per call. As numpy operations over
(things × rays) arrays the cost is numpy's per-call overhead on small arrays (a call cost
~300 µs, almost all of it overhead); compiled, it is three plain loops (rays, agents, segments)
that touch each value once, an order of magnitude faster.

The arithmetic is the numpy version's, operation for operation and in the same precision
(float64, a multiply by the reciprocal where numpy multiplied by one, no fused multiply-add, no
fastmath), and the minimum and maximum keep numpy's rules (NaN propagates, the second operand on
a tie). numba's `math.sin`/`cos`/`hypot` are the C library's scalar functions, which
numpy's vectorised ones may differ from in the last bit on some CPUs, so readings equal the
numpy version's to that (`tests/tasks/fluids/sim/qlidar_reference.py` keeps the reference and
`tests/tasks/fluids/sim/test_sensor_kernels.py` compares, see `tests/kernel_compare.py`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fluids_bench.core.compiled import kernel
from fluids_bench.tasks.fluids.sim.crosswalks import crosswalk_occupied
from fluids_bench.tasks.fluids.sim.layout.compiled import PEDESTRIAN

# lengths of the explicit observation's blocks: ego, goal, each of the k nearest agents, light
EGO, GOAL, PER_AGENT, LIGHT = 5, 3, 7, 5


@kernel
def _minimum(a, b):  # pragma: no cover (compiled)
    """`np.minimum(a, b)`: NaN if either is NaN, `b` on a tie (so min(-0.0, 0.0) is 0.0)."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a < b else b


@kernel
def _maximum(a, b):  # pragma: no cover (compiled)
    """`np.maximum(a, b)`: NaN if either is NaN, `b` on a tie."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a > b else b


@njit(cache=True, nogil=True, error_model="numpy")
def qlidar_cast(
    state,
    active,
    length,
    width,
    is_car,
    ego,
    cos_k,
    sin_k,
    max_range,
    edge_a,
    edge_e,
    edge_angle,
    edge_mid,
    edge_half,
    labels,
    out,
):  # pragma: no cover (compiled)
    """Fill `out` (m, 4) with the noiseless quasi-LIDAR reading of agent `ego`.

    state: (N, 4) [x, y, θ, v] of all agents; active, is_car: (N,) bool; length, width: (N,)
    (m); cos_k, sin_k: (m,) cos and sin of each ray's offset from the ego's heading; edge_a,
    edge_e, edge_mid: (S, 2) start, vector and midpoint of each kerb segment; edge_angle,
    edge_half: (S,) its direction (rad) and half-length (m); labels: the label codes
    [nothing, car, pedestrian, road edge].

    Each ray keeps the nearest hit closer than `max_range` (the first one on ties: agents
    before segments, then by index) and reads [distance, label, relative angle, relative
    speed]; with no such hit it reads `max_range`, the "nothing" label, 0 and 0.
    """
    x, y, th, v = state[ego, 0], state[ego, 1], state[ego, 2], state[ego, 3]
    ct, st = math.cos(th), math.sin(th)

    # agents that may be hit (centre within max_range + half-diagonal), in index order, and
    # each one's slabs, in its own frame relative to the ray origin:
    # [-l/2, l/2] + p_x along its heading, [-w/2, w/2] + p_y across it
    n_agents = 0
    agent = np.empty(len(state), np.int64)
    a_cos, a_sin = np.empty(len(state)), np.empty(len(state))
    slab = np.empty((len(state), 4))  # x0, y0, x1, y1
    for j in range(len(state)):
        rx, ry = state[j, 0] - x, state[j, 1] - y
        reach = max_range + math.hypot(length[j], width[j]) / 2
        if j == ego or not active[j] or not math.hypot(rx, ry) <= reach:
            continue
        c, s = math.cos(state[j, 2]), math.sin(state[j, 2])
        px, py = c * rx + s * ry, c * ry - s * rx  # the centre in the agent's frame
        hl, hw = length[j] / 2, width[j] / 2
        agent[n_agents], a_cos[n_agents], a_sin[n_agents] = j, c, s
        slab[n_agents, 0], slab[n_agents, 1] = -hl + px, -hw + py
        slab[n_agents, 2], slab[n_agents, 3] = hl + px, hw + py
        n_agents += 1

    # kerb segments that may be hit (midpoint within max_range + half-length), in index order:
    # w = start − ray origin, the segment's vector e, and w × e (the same for every ray)
    n_edges = 0
    edge = np.empty(len(edge_a), np.int64)
    seg = np.empty((len(edge_a), 5))  # wx, wy, ex, ey, w × e
    for i in range(len(edge_a)):
        if not math.hypot(edge_mid[i, 0] - x, edge_mid[i, 1] - y) <= max_range + edge_half[i]:
            continue
        wx, wy, ex, ey = edge_a[i, 0] - x, edge_a[i, 1] - y, edge_e[i, 0], edge_e[i, 1]
        edge[n_edges] = i
        seg[n_edges, 0], seg[n_edges, 1], seg[n_edges, 2], seg[n_edges, 3] = wx, wy, ex, ey
        seg[n_edges, 4] = wx * ey - wy * ex
        n_edges += 1

    for k in range(len(cos_k)):
        # the ray's direction d (and −d's x, as numpy computed it: it may differ from −dx in
        # the sign of a zero, which only flips the sign of a zero u below)
        dx = ct * cos_k[k] - st * sin_k[k]
        dy = ct * sin_k[k] + st * cos_k[k]
        ndx = st * sin_k[k] - ct * cos_k[k]
        best, hit, hit_edge = max_range, -1, False
        for n in range(n_agents):
            # slab test in the agent's frame: the ray is inside the x slab for t in
            # [lo_x, hi_x], inside the y slab for t in [lo_y, hi_y]; a hit where both
            # overlap ahead of the origin (false with a NaN, as each comparison is)
            c, s = a_cos[n], a_sin[n]
            inv_ux = 1.0 / (c * dx + s * dy)
            inv_uy = 1.0 / (c * dy - s * dx)
            t1, t2 = slab[n, 0] * inv_ux, slab[n, 2] * inv_ux
            t3, t4 = slab[n, 1] * inv_uy, slab[n, 3] * inv_uy
            near = _maximum(_minimum(t1, t2), _minimum(t3, t4))
            far = _minimum(_maximum(t1, t2), _maximum(t3, t4))
            near = _maximum(near, 0.0)
            if near <= far and near < best:
                best, hit = near, n
        for n in range(n_edges):
            # the ray crosses the segment's line at t = (w × e) / (d × e) along the ray and
            # u = (w × d) / (d × e) along the segment: a hit for t ≥ 0 and 0 ≤ u ≤ 1
            wx, wy, ex, ey = seg[n, 0], seg[n, 1], seg[n, 2], seg[n, 3]
            d_cross_e = ey * dx - ex * dy
            t = seg[n, 4] / d_cross_e
            u = (wx * dy + wy * ndx) / d_cross_e
            if t >= 0 and u >= 0 and u <= 1 and t < best:
                best, hit, hit_edge = t, n, True
        # what was hit: its label, heading and speed; the relative angle is wrapped to
        # [−π, π) for agents and "nothing" (whose heading is the ego's), folded to [−π/2, π/2)
        # for a kerb segment, whose speed is −0.0 (so its relative speed is −v)
        if hit < 0:
            label, heading, speed, half = labels[0], th, v, math.pi
        elif hit_edge:
            i = edge[hit]
            label, heading, speed, half = labels[3], edge_angle[i], -0.0, math.pi / 2
        else:
            j = agent[hit]
            label = labels[1] if is_car[j] else labels[2]
            heading, speed, half = state[j, 2], state[j, 3], math.pi
        out[k, 0] = best
        out[k, 1] = label
        out[k, 2] = (heading - th + half) % (2 * half) - half
        out[k, 3] = speed - v
    return out


@kernel
def qlidar_noise(reading, noise, dropped, max_range, speed_bound):  # pragma: no cover (compiled)
    """Apply drawn noise to a quasi-LIDAR `reading` (m, 4), in place: `noise` (m, 3) is added
    to distance (then clipped to [0, max_range]), angle (wrapped to [-π, π)) and speed (clipped
    to ±speed_bound); rays where `dropped` (m,) read as empty. Either may be empty (m = 0
    rows: that source is off). `np.clip`'s rules, so bit-identical to the array version."""
    for r in range(len(noise)):
        reading[r, 0] = _minimum(_maximum(reading[r, 0] + noise[r, 0], 0.0), max_range)
        reading[r, 2] = (reading[r, 2] + noise[r, 1] + math.pi) % (2 * math.pi) - math.pi
        reading[r, 3] = _minimum(_maximum(reading[r, 3] + noise[r, 2], -speed_bound), speed_bound)
    for r in range(len(dropped)):
        if dropped[r]:
            reading[r, 0], reading[r, 1], reading[r, 2], reading[r, 3] = (
                max_range,
                0.0,
                0.0,
                0.0,
            )  # nothing


@kernel
def fill_explicit(
    out,
    state,
    active,
    kind,
    path_z,
    path_len,
    s,
    offset,
    length,
    route,
    route_light,
    stop_s,
    light_state,
    ego,
    k,
    spacing,
):  # pragma: no cover (compiled)
    """Writes the noiseless observation of agent `ego` into `out` (zeros, float64)."""
    x, y, th, v = state[ego, 0], state[ego, 1], state[ego, 2], state[ego, 3]
    c, sn = math.cos(th), math.sin(th)
    goal = path_z[ego, np.int64(np.rint(path_len[ego] / spacing))]
    dx, dy = goal.real - x, goal.imag - y
    out[0], out[1], out[2], out[3], out[4] = x, y, c, sn, v
    out[5], out[6], out[7] = c * dx + sn * dy, -sn * dx + c * dy, path_len[ego] - s[ego]
    # the k nearest other active agents, nearest first (ties by index: a stable insertion sort)
    others = np.empty(len(state), np.int64)
    dist = np.empty(len(state))
    n = 0
    for j in range(len(state)):
        if not active[j] or j == ego:
            continue
        d = math.hypot(state[j, 0] - x, state[j, 1] - y)
        m = n
        while m > 0 and dist[m - 1] > d:
            dist[m], others[m] = dist[m - 1], others[m - 1]
            m -= 1
        dist[m], others[m] = d, j
        n += 1
    row = EGO + GOAL
    for j in others[: min(n, k)]:
        rx, ry = state[j, 0] - x, state[j, 1] - y
        out[row], out[row + 1] = c * rx + sn * ry, -sn * rx + c * ry
        out[row + 2], out[row + 3] = math.cos(state[j, 2] - th), math.sin(state[j, 2] - th)
        out[row + 4], out[row + 5], out[row + 6] = (
            state[j, 3],
            1.0 if kind[j] == PEDESTRIAN else 0.0,
            1.0,
        )
        row += PER_AGENT
    # the ego's own light: one-hot of its state and the gap to the stop line, or "none"
    base = EGO + GOAL + PER_AGENT * k
    r = route[ego]
    light = route_light[r]
    gap = stop_s[r] - (s[ego] + offset[ego] + length[ego] / 2)
    if light >= 0 and gap > -0.5:
        out[base + light_state[light]] = 1.0
        out[base + 4] = max(gap, 0.0)
    else:
        out[base + 3] = 1.0


@kernel
def qlidar_segments(
    out, x, y, th, v, cos_k, sin_k, seg_a, seg_e, seg_angle, seg_label
):  # pragma: no cover (compiled)
    """Let the first `len(cos_k)` rays of a cast reading `out` also stop at extra segments
    (the quasi-LIDAR v1's stop lines of red and yellow lights and occupied crosswalks' edges):
    where a ray crosses segment i nearer than its current hit, it reads [distance,
    `seg_label[i]`, the segment's direction relative to the ego folded to [−π/2, π/2), −v].

    x, y, th, v: the ego's pose and speed; seg_a, seg_e: (S, 2) start and vector of each
    segment; seg_angle: (S,) its direction (rad, folded to [−π/2, π/2)).
    """
    ct, st = math.cos(th), math.sin(th)
    half = math.pi / 2
    for k in range(len(cos_k)):
        dx = ct * cos_k[k] - st * sin_k[k]
        dy = ct * sin_k[k] + st * cos_k[k]
        best, hit = out[k, 0], -1
        for i in range(len(seg_a)):
            wx, wy = seg_a[i, 0] - x, seg_a[i, 1] - y
            ex, ey = seg_e[i, 0], seg_e[i, 1]
            d_cross_e = ey * dx - ex * dy
            if d_cross_e == 0.0:
                continue  # parallel
            t = (wx * ey - wy * ex) / d_cross_e
            u = (wx * dy - wy * dx) / d_cross_e
            if t >= 0 and u >= 0 and u <= 1 and t < best:
                best, hit = t, i
        if hit >= 0:
            out[k, 0] = best
            out[k, 1] = seg_label[hit]
            out[k, 2] = (seg_angle[hit] - th + half) % (2 * half) - half
            out[k, 3] = -0.0 - v


@kernel
def qlidar_v1_extras(
    out,
    state,
    active,
    is_car,
    width,
    ego,
    cos_k,
    sin_k,
    line_a,
    line_e,
    line_angle,
    line_light,
    light_state,
    stop_code,
    caution_code,
    cw_a,
    cw_e,
    cw_angle,
    cw_centre,
    cw_axis,
    cw_half,
    labels,
    goal_x,
    goal_y,
    max_range,
):  # pragma: no cover (compiled)
    """Everything the quasi-LIDAR v1 adds to a cast reading `out` (m + 1, 4), in one pass:
    the stop lines whose light shows `stop_code` or `caution_code` and the edges of every
    crosswalk with an active pedestrian on it join the obstacles (`qlidar_segments`),
    and row m becomes the goal row towards (goal_x, goal_y).

    line_*: (L, ...) stop lines (start, vector, folded direction, light index); cw_a, cw_e,
    cw_angle: (C, 4, ...) crosswalk edges; cw_centre, cw_axis: (C, 2) centre and unit axis;
    cw_half: (C, 2) half length and half width; labels: [red, yellow, pedestrian, goal].
    """
    n_seg = 0
    seg_a = np.empty((len(line_a) + 4 * len(cw_a), 2))
    seg_e = np.empty((len(line_a) + 4 * len(cw_a), 2))
    seg_angle = np.empty(len(line_a) + 4 * len(cw_a))
    seg_label = np.empty(len(line_a) + 4 * len(cw_a))
    for i in range(len(line_a)):
        code = light_state[line_light[i]] if len(light_state) else -1
        if code == stop_code or code == caution_code:
            seg_a[n_seg], seg_e[n_seg] = line_a[i], line_e[i]
            seg_angle[n_seg] = line_angle[i]
            seg_label[n_seg] = labels[0] if code == stop_code else labels[1]
            n_seg += 1
    for c in range(len(cw_a)):
        if crosswalk_occupied(c, state, active, is_car, width, cw_centre, cw_axis, cw_half):
            for q in range(4):
                seg_a[n_seg], seg_e[n_seg] = cw_a[c, q], cw_e[c, q]
                seg_angle[n_seg], seg_label[n_seg] = cw_angle[c, q], labels[2]
                n_seg += 1
    x, y, th, v = state[ego, 0], state[ego, 1], state[ego, 2], state[ego, 3]
    if n_seg:
        qlidar_segments(
            out, x, y, th, v, cos_k, sin_k,
            seg_a[:n_seg], seg_e[:n_seg], seg_angle[:n_seg], seg_label[:n_seg],
        )  # fmt: skip
    dx, dy = goal_x - x, goal_y - y
    m = len(cos_k)
    out[m, 0] = min(math.hypot(dx, dy), max_range)
    out[m, 1] = labels[3]
    out[m, 2] = (math.atan2(dy, dx) - th + math.pi) % (2 * math.pi) - math.pi
    out[m, 3] = -0.0 - v
