"""Compiled per-step loops of the world (numba): progress along paths, the quick on-road test
and the collision broad phase (the dynamics' loop is in `fluids_bench.tasks.fluids.sim.dynamics`).

A FLUIDS scene has tens of agents, so each of these is a few dozen arithmetic operations per
agent (or per pair). As numpy expressions they cost one call of 1–2 µs per operation on these
machines, which made them most of a step; compiled they are plain loops. The arithmetic is the
numpy formulation's, operation for operation in float64 with no fast-math (no fused
multiply-add); only sin/cos/hypot are the C library's scalar functions, which numpy's vectorised
ones may differ from in the last bit on some CPUs. `tests/tasks/fluids/sim/numpy_reference.py`
keeps those formulations and `tests/tasks/fluids/sim/test_sim_kernels.py` compares. Data stays in the world's arrays
(struct of arrays over agents); nothing here allocates per agent.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fluids_bench.core.compiled import callee, kernel
from fluids_bench.tasks.fluids.sim.dynamics import advance, wrap_angle


@kernel
def progress_into(
    state,
    s,
    active,
    path_z,
    path_heading,
    path_len,
    spacing,
    lo,
    hi,
    nearest,
    lateral,
    heading_error,
):  # pragma: no cover (compiled)
    """Each agent projected onto its path near its previous progress `s`: the path samples
    `lo` … `hi − 1` around it are searched (an agent moves a few samples per step at most).

    In place: progress `s` (m; kept for inactive agents; each agent reads only its own old
    value), the `nearest` sample, and the signed `lateral` offset (m, left positive) and
    `heading_error` (rad) from that sample."""
    n, width = path_z.shape
    for i in range(n):
        x, y = state[i, 0], state[i, 1]
        k0 = np.int64(np.rint(s[i] / spacing))
        best, best_d = 0, np.inf
        for w in range(lo, hi):
            k = min(max(k0 + w, 0), width - 1)
            dx, dy = path_z[i, k].real - x, path_z[i, k].imag - y
            d = dx * dx + dy * dy
            if d < best_d:  # the first of equal distances, as argmin
                best, best_d = k, d
        h = path_heading[i, best]
        ox, oy = x - path_z[i, best].real, y - path_z[i, best].imag
        ch, sh = math.cos(h), math.sin(h)
        along = min(max(ox * ch + oy * sh, -spacing / 2), spacing / 2)
        if active[i]:
            s[i] = min(best * spacing + along, path_len[i])
        nearest[i] = best
        lateral[i] = oy * ch - ox * sh
        heading_error[i] = wrap_angle(state[i, 2] - h)


@kernel
def surely_on_road(
    state, nearest, offsets, samples, radius, path_z, clearance
):  # pragma: no cover (compiled)
    """Agents each of whose covering circles (centred `offsets` (N, 3) m along the heading,
    `radius` (N,) m) lies within the road clearance of the path sample nearest it (the agent's
    nearest sample plus `samples` (N, 3)): their footprints are certainly on the road."""
    out = np.empty(path_z.shape[0], np.bool_)
    surely_on_road_into(state, nearest, offsets, samples, radius, path_z, clearance, out)
    return out


@njit(cache=True, nogil=True, inline="always")
def surely_on_road_into(
    state, nearest, offsets, samples, radius, path_z, clearance, out
):  # pragma: no cover (compiled)
    """`surely_on_road` written into `out`."""
    n, width = path_z.shape
    for i in range(n):
        x, y = state[i, 0], state[i, 1]
        c, s = math.cos(state[i, 2]), math.sin(state[i, 2])
        out[i] = True
        for j in range(3):
            k = min(max(nearest[i] + samples[i, j], 0), width - 1)
            gap = math.hypot(
                x + offsets[i, j] * c - path_z[i, k].real, y + offsets[i, j] * s - path_z[i, k].imag
            )
            if not gap + radius[i] < clearance[i, k]:
                out[i] = False
                break
    return out


@kernel
def touching_pairs(state, active, reach2, offsets, radius):  # pragma: no cover (compiled)
    """Pairs (a, b), a < b, of active agents whose covering circles meet: first their
    circumscribed circles (`reach2` (N, N), the squared sum of their radii; negative for pairs
    never checked), then the three circles along each (`offsets` (N, 3) m along the heading,
    `radius` (N,) m). Disjoint circles prove two footprints apart; the rest go to Shapely."""
    n = state.shape[0]
    first, second = [], []
    for a in range(n):
        if not active[a]:
            continue
        for b in range(a + 1, n):
            if active[b] and _circles_meet(state, a, b, reach2, offsets, radius):
                first.append(a)
                second.append(b)
    return np.array(first, dtype=np.int64), np.array(second, dtype=np.int64)


@njit(cache=True, nogil=True, inline="always")
def _circles_meet(state, a, b, reach2, offsets, radius):  # pragma: no cover (compiled)
    """Whether the covering circles of agents `a` and `b` meet (see `touching_pairs`)."""
    gx, gy = state[a, 0] - state[b, 0], state[a, 1] - state[b, 1]
    if not gx * gx + gy * gy < reach2[a, b]:
        return False
    ca, sa = math.cos(state[a, 2]), math.sin(state[a, 2])
    cb, sb = math.cos(state[b, 2]), math.sin(state[b, 2])
    limit = (radius[a] + radius[b]) * (radius[a] + radius[b])
    meet = False
    for i in range(3):
        xa, ya = state[a, 0] + offsets[a, i] * ca, state[a, 1] + offsets[a, i] * sa
        for j in range(3):
            dx = xa - (state[b, 0] + offsets[b, j] * cb)
            dy = ya - (state[b, 1] + offsets[b, j] * sb)
            meet |= dx * dx + dy * dy < limit
    return meet


@njit(cache=True, nogil=True, inline="always")
def any_touching(state, active, reach2, offsets, radius):  # pragma: no cover (compiled)
    """Whether `touching_pairs` would find any pair."""
    n = state.shape[0]
    for a in range(n):
        if active[a]:
            for b in range(a + 1, n):
                if active[b] and _circles_meet(state, a, b, reach2, offsets, radius):
                    return True
    return False


@callee
def mark_arrived(s, path_len, length, tolerance, active, reached):  # pragma: no cover
    """In place: each active agent whose front is within `tolerance` (m) of its path's end
    (`s >= path_len - length / 2 - tolerance`) has reached it and is no longer active."""
    for i in range(s.shape[0]):
        if active[i] and s[i] >= path_len[i] - length[i] / 2 - tolerance:
            reached[i] = True
            active[i] = False


@kernel
def mark_entered(s, offset, front, route, enter_s, active, entered, step):  # pragma: no cover
    """In place: `entered[i] = step` for each active agent on a route whose front has reached
    its route's `enter_s` and that had not entered before (`World.entered`)."""
    for i in range(s.shape[0]):
        r = route[i]
        if entered[i] < 0 and active[i] and r >= 0 and s[i] + offset[i] + front[i] >= enter_s[r]:
            entered[i] = step


@njit(cache=True, nogil=True, inline="always")
def record_fault_step(
    route_s, front, enter, light_of, prev_lights, lights, stop, entry_step, ran_red, step,
    state, ring, slot,
):  # fmt: skip
    """One step of `FaultTracker`, in place: an
    agent whose front passed its zone's start (`route_s + front >= enter`) enters now (its
    `enter` becomes inf: once only), having run a red light when its light (`light_of`, -1:
    none) showed `stop` on the previous step; then this step's lights become the previous
    ones and the agents' state goes into history slot `slot` of `ring`."""
    for i in range(route_s.shape[0]):
        if route_s[i] + front[i] >= enter[i]:
            entry_step[i] = step
            enter[i] = np.inf
            li = light_of[i]
            ran_red[i] = li >= 0 and li < prev_lights.shape[0] and prev_lights[li] == stop
    for k in range(lights.shape[0]):
        prev_lights[k] = lights[k]
    for i in range(state.shape[0]):
        for j in range(state.shape[1]):
            ring[slot, i, j] = state[i, j]


@kernel
def advance_world(
    state, controls, is_car, params, dt, active, s, offset, path_z, path_heading, path_len,
    clearance, spacing, lo, hi, nearest, lateral, heading_error, front, route, enter_s, entered,
    step, length, tolerance, reached, circle_offsets, circle_samples, circle_radius, reach2,
    offroad_candidates,
):  # fmt: skip
    """One world step's per-agent arithmetic in one compiled call, in place, in
    `World.step`'s order: the dynamics (`advance`), progress along the
    paths (`progress_into`), zone entries at step `step` (`mark_entered`),
    arrivals (`mark_arrived`), then the broad phase of the collision check: writes
    `offroad_candidates` (active cars not surely on the road, `surely_on_road`) and
    returns whether any candidate exists or any two agents' covering circles meet (False: the
    step has no collision, and Shapely need not be called)."""
    advance(state, controls, is_car, params, dt, active)
    progress_into(
        state, s, active, path_z, path_heading, path_len, spacing, lo, hi, nearest, lateral,
        heading_error,
    )  # fmt: skip
    mark_entered(s, offset, front, route, enter_s, active, entered, step)
    mark_arrived(s, path_len, length, tolerance, active, reached)
    surely_on_road_into(
        state, nearest, circle_offsets, circle_samples, circle_radius, path_z, clearance,
        offroad_candidates,
    )  # fmt: skip
    candidates = False
    for i in range(state.shape[0]):
        offroad_candidates[i] = is_car[i] and active[i] and not offroad_candidates[i]
        candidates |= offroad_candidates[i]
    return candidates or any_touching(state, active, reach2, circle_offsets, circle_radius)


@kernel
def advance_worlds(
    stepping, state, controls, is_car, params, dt, active, s, offset, path_z, path_heading,
    path_len, clearance, spacing, lo, hi, nearest, lateral, heading_error, front, route,
    enter_s, entered, steps, length, tolerance, reached, circle_offsets, circle_samples,
    circle_radius, reach2, offroad_candidates, maybe_collided,
):  # fmt: skip  # pragma: no cover (compiled)
    """`advance_world` on row `b` of every per-world array, for each world `b` where
    `stepping[b]` (the arrays without a batch axis are shared by all worlds); writes each
    stepped world's result into `maybe_collided[b]`."""
    for b in range(len(stepping)):
        if stepping[b]:
            maybe_collided[b] = advance_world(
                state[b], controls[b], is_car, params[b], dt, active[b], s[b], offset[b],
                path_z[b], path_heading[b], path_len[b], clearance[b], spacing, lo, hi,
                nearest[b], lateral[b], heading_error[b], front, route[b], enter_s, entered[b],
                steps[b], length, tolerance, reached[b], circle_offsets, circle_samples,
                circle_radius, reach2, offroad_candidates[b],
            )  # fmt: skip
