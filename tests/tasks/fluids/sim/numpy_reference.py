"""The simulator's per-step loops as the numpy array expressions they were before being compiled
(``fluids_bench/tasks/fluids/sim/kernels.py``). ``test_sim_kernels.py`` holds the kernels to
these, to the tolerance stated in ``tests/kernel_compare.py``."""

from __future__ import annotations

import numpy as np

from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING

_THIRDS = np.array([-1.0, 0.0, 1.0])


def integrate(state, controls, is_car, params, dt):
    x, y, th, v = state.T
    psi, u = controls.T
    mass, lf, lr, vmax = params.T
    beta = np.arctan(lr / (lf + lr) * np.tan(psi))
    accel = np.where(is_car, u / mass, u)
    heading = np.where(is_car, th + beta, psi)
    new = np.empty_like(state)
    new[:, 0] = x + v * np.cos(heading) * dt
    new[:, 1] = y + v * np.sin(heading) * dt
    new[:, 2] = np.where(is_car, th + v / lr * np.sin(beta) * dt, psi)
    new[:, 2] = (new[:, 2] + np.pi) % (2 * np.pi) - np.pi
    new[:, 3] = np.minimum(np.maximum(v + accel * dt, 0.0), vmax)
    return new


def progress(world):
    """(s, nearest, lateral error, heading error) as ``World._update_progress`` computed them."""
    w = world
    width = w.path_z.shape[1]
    k = np.rint(w.s / PATH_SPACING).astype(np.int64)[:, None] + np.arange(-3, 9)  # the window
    np.minimum(np.maximum(k, 0, out=k), width - 1, out=k)
    row_start = np.arange(w.n)[:, None] * width
    k += row_start
    pos = w.state[:, 0] + 1j * w.state[:, 1]
    paths = w.path_z.ravel()
    d = paths.take(k) - pos[:, None]
    best = k[np.arange(w.n), (d.real * d.real + d.imag * d.imag).argmin(axis=1)]
    h = w.path_heading.ravel().take(best)
    off = pos - paths.take(best)
    best -= row_start[:, 0]
    ch, sh = np.cos(h), np.sin(h)
    along = np.minimum(
        np.maximum(off.real * ch + off.imag * sh, -PATH_SPACING / 2), PATH_SPACING / 2
    )
    s = np.where(w.active, np.minimum(best * PATH_SPACING + along, w.path_len), w.s)
    lateral = off.imag * ch - off.real * sh
    heading_error = (w.state[:, 2] - h + np.pi) % (2 * np.pi) - np.pi
    return s, best, lateral, heading_error


def surely_on_road(world):
    w = world
    width = w.path_z.shape[1]
    thirds = np.outer(np.where(w.is_car, w.length / 3, 0.0), _THIRDS)
    heading = np.exp(1j * w.state[:, 2])
    centres = (w.state[:, 0] + 1j * w.state[:, 1])[:, None] + thirds * heading[:, None]
    k = w.nearest[:, None] + np.rint(thirds / PATH_SPACING).astype(np.int64)
    np.minimum(np.maximum(k, 0, out=k), width - 1, out=k)
    k += np.arange(w.n)[:, None] * width
    radius = np.hypot(w.length / 6, w.width / 2)[:, None]
    reach = np.abs(centres - w.path_z.ravel().take(k)) + radius
    return (reach < w.path_clearance.ravel().take(k)).all(axis=1)


def touching_pairs(state, length, width, is_car, active):
    """Pairs (a, b), a < b, at least one a car, whose covering circles meet."""
    centre = state[:, 0] + 1j * state[:, 1]
    half_diag = 0.5 * np.hypot(length, width)
    reach = half_diag[:, None] + half_diag[None, :]
    reach2 = np.where(np.triu(is_car[:, None] | is_car[None, :], k=1), reach * reach, -1.0)
    gap = centre[:, None] - centre[None, :]
    near = gap.real**2 + gap.imag**2 < reach2
    near &= np.logical_and.outer(active, active)
    a, b = near.nonzero()
    heading = np.exp(1j * state[:, 2])
    circles = centre[:, None] + (np.where(is_car, length / 3, 0.0) * heading)[:, None] * _THIRDS
    radius = np.hypot(np.where(is_car, length / 6, length / 2), width / 2)
    g = circles[a][:, :, None] - circles[b][:, None, :]
    near = (g.real**2 + g.imag**2).min(axis=(1, 2)) < (radius[a] + radius[b]) ** 2
    return a[near], b[near]


def explicit(world, k_nearest, ego=0):
    """The noiseless explicit observation (float64) as ``ExplicitSensor`` computed it."""
    from fluids_bench.tasks.fluids.sim.layout.compiled import PEDESTRIAN
    from fluids_bench.tasks.fluids.sim.sensors.explicit import EGO, GOAL, PER_AGENT, explicit_size

    out = np.zeros(explicit_size(k_nearest), dtype=np.float64)
    state = world.state
    x, y, th, v = state[ego].tolist()
    c, s = float(np.cos(th)), float(np.sin(th))
    goal = world.path_z[ego, int(round(world.path_len[ego] / 0.5))]
    dx, dy = goal.real - x, goal.imag - y
    out[: EGO + GOAL] = (
        x,
        y,
        c,
        s,
        v,
        c * dx + s * dy,
        -s * dx + c * dy,
        float(world.path_len[ego] - world.s[ego]),
    )
    seen = world.active.copy()
    seen[ego] = False
    others = seen.nonzero()[0]
    if len(others):
        rel = state[others, :2] - (x, y)
        order = np.argsort(np.hypot(rel[:, 0], rel[:, 1]), kind="stable")[:k_nearest]
        idx, rel = others[order], rel[order]
        dth = state[idx, 2] - th
        rows = out[EGO + GOAL : EGO + GOAL + PER_AGENT * len(idx)].reshape(-1, PER_AGENT)
        rows[:, 0] = c * rel[:, 0] + s * rel[:, 1]
        rows[:, 1] = -s * rel[:, 0] + c * rel[:, 1]
        rows[:, 2] = np.cos(dth)
        rows[:, 3] = np.sin(dth)
        rows[:, 4] = state[idx, 3]
        rows[:, 5] = world.kind[idx] == PEDESTRIAN
        rows[:, 6] = 1.0
    base = EGO + GOAL + PER_AGENT * k_nearest
    routes = world.layout.routes
    r = world.route[ego]
    light = routes.light[r]
    gap = float(routes.stop_s[r] - (world.s[ego] + world.offset[ego] + world.length[ego] / 2))
    if light >= 0 and gap > -0.5:
        out[base + int(world.light_state[light])] = 1.0
        out[base + 4] = max(gap, 0.0)
    else:
        out[base + 3] = 1.0
    return out
