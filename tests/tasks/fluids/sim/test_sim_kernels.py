"""The simulator's compiled loops (world step, arrivals, explicit observation) against the numpy
formulations they replaced (tolerances and why: ``tests/kernel_compare.py``).

States come from seeded supervised episodes on every layout builder, every few steps, with
agents often jostled off their paths and into each other, so that near misses, collisions and
cars off the road are all covered.
"""

from __future__ import annotations

import numpy as np
import numpy_reference as ref
import pytest
from kernel_compare import assert_kernel_close

from fluids_bench.tasks.fluids.sim import kernels
from fluids_bench.tasks.fluids.sim.collision import covering_circles
from fluids_bench.tasks.fluids.sim.config import SceneConfig
from fluids_bench.tasks.fluids.sim.dynamics import integrate
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.sim.sensors.explicit import ExplicitSensor
from fluids_bench.tasks.fluids.sim.world import GOAL_TOLERANCE, PROGRESS_WINDOW
from fluids_bench.tasks.fluids.supervisor.episode import make_world
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor


def _states(layout: str, seed: int):
    world = make_world(SceneConfig(layout=layout, num_cars=8, num_pedestrians=5), seed)
    sup = DrivingSupervisor(world)
    rng = np.random.default_rng(seed)
    for step in range(200):
        sup.step(world)
        if step % 10 == 3:
            if step % 20 == 3:  # knock agents about: near misses, overlaps, odd headings
                world.state[:, :3] += rng.normal(0.0, [1.5, 1.5, 0.5], (world.n, 3))
                world.state[:, 3] = rng.uniform(0.0, 8.0, world.n)
            yield world, rng


@pytest.mark.parametrize("layout", ["four_way", "t_junction", "roundabout"])
@pytest.mark.parametrize("seed", [0, 1])
def test_world_kernels_equal_the_numpy_reference(layout, seed):
    pairs_seen = unsure_seen = arrivals_seen = 0
    for world, rng in _states(layout, seed):
        w = world
        # dynamics, with controls past every limit and some agents inactive
        controls = np.column_stack([rng.uniform(-1.5, 1.5, w.n), rng.uniform(-9000.0, 9000.0, w.n)])
        active = rng.random(w.n) < 0.8
        want = np.where(
            active[:, None], ref.integrate(w.state, controls, w.is_car, w.params, w.dt), w.state
        )
        assert_kernel_close(integrate(w.state, controls, w.is_car, w.params, w.dt, active), want)
        # progress along the paths (in place, into copies: the reference reads the world's)
        got = (w.s.copy(), np.empty(w.n, np.int64), np.empty(w.n), np.empty(w.n))
        kernels.progress_into(
            w.state, got[0], w.active, w.path_z, w.path_heading, w.path_len, PATH_SPACING,
            *PROGRESS_WINDOW, *got[1:],
        )  # fmt: skip
        for g, r in zip(got, ref.progress(w), strict=True):
            assert_kernel_close(g, r)
        # arrival at the end of the path (every agent's progress moved near its end)
        s = w.path_len - w.length / 2 - rng.uniform(-1.0, 1.5, w.n)
        active, reached = rng.random(w.n) < 0.8, rng.random(w.n) < 0.2
        arrived = active & (s >= w.path_len - w.length / 2 - GOAL_TOLERANCE)
        want_active, want_reached = active & ~arrived, reached | arrived
        kernels.mark_arrived(s, w.path_len, w.length, GOAL_TOLERANCE, active, reached)
        np.testing.assert_array_equal(active, want_active)
        np.testing.assert_array_equal(reached, want_reached)
        arrivals_seen += int(arrived.sum())
        # the quick on-road test
        sure = w.surely_on_road()
        np.testing.assert_array_equal(sure[w.is_car], ref.surely_on_road(w)[w.is_car])  # cars only
        unsure_seen += int((~sure & w.is_car & w.active).sum())
        # the collision broad phase
        a, b = kernels.touching_pairs(
            w.state, w.active, *covering_circles(w.is_car, w.length, w.width)
        )
        ra, rb = ref.touching_pairs(w.state, w.length, w.width, w.is_car, w.active)
        np.testing.assert_array_equal(a, ra)
        np.testing.assert_array_equal(b, rb)
        pairs_seen += len(a)
        # the explicit observation, of several agents, with more and fewer slots than others
        for ego in (0, 1, w.n - 1):
            for k in (3, 16):
                got = ExplicitSensor(k).observe(w, rng, ego)
                assert_kernel_close(got, ref.explicit(w, k, ego).astype(np.float32))
    # the comparison saw contacts, cars off the road and arrivals
    assert pairs_seen > 0 and unsure_seen > 0 and arrivals_seen > 0


def test_angles_wrap_like_numpy_at_the_edges():
    """Pedestrians only (no trigonometry): the wrap is the same scalar arithmetic on both sides,
    so bit for bit."""
    angles = np.array(
        [
            -np.pi,
            np.pi,
            3 * np.pi,
            -3 * np.pi,
            0.0,
            -0.0,
            1e-300,
            np.nextafter(np.pi, 0),
            np.nextafter(-np.pi, 0),
            100.0,
            -100.0,
        ]
    )
    n = len(angles)
    state = np.column_stack([np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)])
    controls = np.column_stack([angles, np.zeros(n)])  # pedestrians take the heading they are given
    is_car, params = np.zeros(n, dtype=bool), np.tile([1.0, 1.0, 1.0, 2.0], (n, 1))
    np.testing.assert_array_equal(
        integrate(state, controls, is_car, params, 0.1),
        ref.integrate(state, controls, is_car, params, 0.1),
    )
