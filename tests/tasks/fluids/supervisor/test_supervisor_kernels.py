"""The supervisor's compiled kernels against plain numpy references (tolerances and why: see
``tests/kernel_compare.py``; the PID's heading uses atan2, which numpy vectorises).

The references are the vectorised formulations the kernels replaced: the allowed speeds
(compared bit for bit: gathers, min/max and sqrt on both sides), whole (A, K, T) speed
profiles with a cumulative sum, (P, K, K, T) pairwise distance arrays, and the PID loops as
array expressions. States come from
seeded supervised episodes and from the same states with agents shuffled about, so that both
near misses and clear roads are covered.
"""

from __future__ import annotations

import numpy as np
import pytest
from kernel_compare import assert_kernel_close

from fluids_bench.tasks.fluids.sim.config import SceneConfig
from fluids_bench.tasks.fluids.supervisor.episode import make_world
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor


def reference_allowed_speed(planner, world, agents):
    k0 = np.rint(world.route_s[agents] / 0.5).astype(np.int64)
    last = world.layout.routes.path.shape[1] - 1
    r, k = world.route[agents], np.minimum(np.maximum(k0[:, None] + np.arange(24), 0), last)
    routes = world.layout.routes
    kappa = routes.curvature[r[:, None], k].max(axis=1)
    limit = routes.speed_limit[r, k[:, 0]]
    curve = np.sqrt(planner.config.lateral_accel / np.maximum(kappa, 1e-6))
    out = np.minimum(world.max_speed[agents], np.minimum(limit, curve))
    return np.where(world.is_car[agents], out, world.max_speed[agents])


def reference_project(planner, world, agents, targets):
    cfg, dt = planner.config, world.dt
    steps = int(round(cfg.horizon / dt))
    n = np.arange(1, steps + 1, dtype=float)
    v0 = world.state[agents, 3][:, None]
    e0 = v0 - targets
    sign = np.sign(e0)
    lim = np.where(e0 < 0, cfg.max_accel, cfg.max_decel)
    n1 = np.maximum(0.0, np.ceil((np.abs(e0) - lim / cfg.speed_gain) / (lim * dt)))
    e1 = e0 - sign * lim * dt * n1
    linear = v0[..., None] - (sign * lim * dt)[..., None] * n
    geometric = targets[..., None] + e1[..., None] * (1.0 - cfg.speed_gain * dt) ** (
        n - n1[..., None]
    )
    v = np.maximum(np.where(n <= n1[..., None], linear, geometric), 0.0)
    v_prev = np.concatenate(
        [np.broadcast_to(v0[..., None], (*targets.shape, 1)), v[..., :-1]], axis=-1
    )
    travelled = np.cumsum(0.5 * (v_prev + v) * dt, axis=-1)[
        ..., cfg.sample_every - 1 :: cfg.sample_every
    ]
    return world.s[agents][:, None, None] + travelled


def reference_conflicts(planner, world, agents, s_proj):
    """(pairs, conflict) as the numpy planner computed them."""
    k = len(planner.fractions)
    pts, dirs = world.path_samples(s_proj, agents)
    bound = planner._reach[agents]  # bounding circle + margin / 2
    pos = (world.state[agents, 0] + 1j * world.state[agents, 1]).astype(np.complex64)
    flat = np.concatenate([pts.reshape(len(agents), -1), pos[:, None]], axis=1)
    lo_x, hi_x = flat.real.min(1) - bound, flat.real.max(1) + bound
    lo_y, hi_y = flat.imag.min(1) - bound, flat.imag.max(1) + bound
    ii, jj = np.triu_indices(len(agents), k=1)
    cars = world.is_car[agents]
    keep = (
        (lo_x[ii] <= hi_x[jj])
        & (lo_x[jj] <= hi_x[ii])
        & (lo_y[ii] <= hi_y[jj])
        & (lo_y[jj] <= hi_y[ii])
        & (cars[ii] | cars[jj])
    )
    ii, jj = ii[keep], jj[keep]
    diff = pts[ii][:, :, None] - pts[jj][:, None, :]  # (P, K, K, T)
    reach = ((bound[ii] + bound[jj]) ** 2).astype(np.float32)
    near = diff.real**2 + diff.imag**2 < reach[:, None, None, None]
    conflict = np.zeros((len(ii), k, k), dtype=bool)
    p, a, b, t = np.nonzero(near)
    offs, radius = planner._offs[agents].astype(np.float32), planner._radius[agents]
    now = pos[:, None] + offs * np.exp(1j * world.state[agents, 2]).astype(np.complex64)[:, None]
    d_now = np.abs(now[ii][:, :, None] - now[jj][:, None, :]).min(axis=(1, 2))
    crossing = ~cars & (
        world.route_s[agents] + planner._front[agents]
        >= world.layout.routes.enter_s[world.route[agents]]
    )
    margin = np.where(
        crossing[ii] | crossing[jj], planner.config.pedestrian_margin, planner.config.margin
    )
    thresh = np.minimum(radius[ii] + radius[jj] + margin, d_now - 0.05)
    circles = pts[..., None] + offs[:, None, None, :] * dirs[..., None]  # (A, K, T, 3)
    dd = circles[ii[p], a, t][:, :, None] - circles[jj[p], b, t][:, None, :]
    d2 = (dd.real**2 + dd.imag**2).min(axis=(1, 2))
    th_p = np.maximum(thresh[p], 0.0)
    hit = d2 < th_p * th_p
    conflict[p[hit], a[hit], b[hit]] = True
    conflict[:, 0, 0] = False
    keep = conflict.any(axis=(1, 2))
    return np.column_stack([ii, jj])[keep], conflict[keep]


def reference_pid(pid, world, target_speed):
    cfg = pid.config
    ahead = np.maximum(pid.min_ahead, pid.ahead_time * world.state[:, 3])
    k = np.rint(np.minimum(world.s + ahead, world.path_len) / 0.5).astype(np.int64)
    aim = world.path[np.arange(world.n), np.clip(k, 0, world.path.shape[1] - 1)]
    state = world.state
    desired = np.arctan2(aim[:, 1] - state[:, 1], aim[:, 0] - state[:, 0])
    err = (desired - state[:, 2] + np.pi) % (2 * np.pi) - np.pi
    integ = pid.steer_int + err * world.dt
    steer = (
        cfg.steer_kp * err + cfg.steer_kd / world.dt * (err - pid.steer_prev) + cfg.steer_ki * integ
    )
    v_err = target_speed - state[:, 3]
    v_int = pid.speed_int + v_err * world.dt
    accel = np.clip(cfg.speed_kp * v_err + cfg.speed_ki * v_int, -cfg.max_decel, cfg.max_accel)
    out = np.column_stack(
        [
            np.clip(steer, -world.scene.car.max_steer, world.scene.car.max_steer),
            np.clip(accel * pid.gain, pid.low, pid.high),
        ]
    )
    out[~world.is_car, 0] = desired[~world.is_car]
    return out, (err, integ, v_int)


def _states(layout: str, seed: int):
    """Planner inputs along a supervised episode, every few steps, some with agents jostled."""
    world = make_world(SceneConfig(layout=layout, num_cars=8, num_pedestrians=4), seed)
    sup = DrivingSupervisor(world)
    rng = np.random.default_rng(seed)
    for step in range(240):
        sup.step(world)
        if step % 12 == 5 and world.active.sum() > 1:
            if step % 24 == 5:  # jostle: near misses, odd headings, agents closer than clearance
                world.state[:, :3] += rng.normal(0.0, [1.0, 1.0, 0.3], (world.n, 3))
                world.state[:, 3] = rng.uniform(0.0, 8.0, world.n)
            yield world, sup.planner


@pytest.mark.parametrize("layout", ["four_way", "t_junction", "roundabout"])
@pytest.mark.parametrize("seed", [0, 1])
def test_kernels_equal_the_numpy_reference(layout, seed):
    checked = conflicts_seen = 0
    for world, planner in _states(layout, seed):
        planner._bind(world)
        agents = world.active.nonzero()[0]
        vmax = planner.allowed_speed(world, agents)
        np.testing.assert_array_equal(vmax, reference_allowed_speed(planner, world, agents))
        targets = vmax[:, None] * planner.fractions
        s_proj = planner.project(world, agents, targets)
        assert_kernel_close(s_proj, reference_project(planner, world, agents, targets))
        pairs, conflict = planner.conflicts(world, agents, s_proj)
        ref_pairs, ref_conflict = reference_conflicts(planner, world, agents, s_proj)
        np.testing.assert_array_equal(pairs, ref_pairs)
        np.testing.assert_array_equal(conflict, ref_conflict)
        checked += 1
        conflicts_seen += int(conflict.sum())
        pid = DrivingSupervisor(world).pid  # fresh loops
        pid.commit(tuple(np.random.default_rng(checked).normal(size=(3, world.n))))  # some memory
        targets = np.random.default_rng(checked).uniform(0.0, 10.0, world.n)
        controls, memory = pid.controls(world, targets)
        ref_controls, ref_memory = reference_pid(pid, world, targets)
        assert_kernel_close(controls, ref_controls)
        for got, want in zip(memory, ref_memory, strict=True):
            assert_kernel_close(got, want)
    assert checked >= 15 and conflicts_seen > 0  # the comparison saw real conflicts
