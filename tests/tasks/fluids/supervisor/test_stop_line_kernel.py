"""The compiled stop lines against the numpy formulation they replaced
(``stop_line_reference.py``), bit for bit: both sides do the same float64 arithmetic with no
transcendental function (see ``tests/kernel_compare.py``).

States come from seeded FLUIDS-v1 episodes (lights obeyed, cars yield to walkers, an
uncontrolled ego) on three layouts, every few steps, and from the same states with agents
jostled and speeds redrawn, so that lights, occupied crosswalks and waiting walkers all hold
agents back.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from stop_line_reference import committed_crosswalks_numpy, reference_domains_and_hold_lines

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.tasks.fluids.sim.crosswalks import committed_crosswalks


def _states(layout: str, seed: int):
    env = gym.make("FLUIDS-v1", layout=layout, num_cars=8, num_pedestrians=6)
    rng = np.random.default_rng(seed)
    _, info = env.reset(seed=seed)
    for step in range(400):
        action = info["supervisor_action"] + rng.normal(0.0, 0.3, 2)
        _, _, term, trunc, info = env.step(np.clip(action, -1.0, 1.0).astype(np.float32))
        if term or trunc:
            _, info = env.reset(seed=seed + 1000 + step)
        if step % 4:
            continue
        u = env.unwrapped
        yield u.world, u.supervisor
        if step % 16 == 8:  # jostle: agents near lines, odd speeds
            world = u.world
            saved = world.state.copy()
            world.state[:, :2] += rng.normal(0.0, 1.5, (world.n, 2))
            world.state[:, 3] = rng.uniform(0.0, 8.0, world.n)
            yield world, u.supervisor
            world.state[:] = saved


@pytest.mark.parametrize("layout", ["four_way", "t_junction", "roundabout"])
def test_stop_line_kernel_equals_the_numpy_reference(layout):
    checked = held = 0
    for world, sup in _states(layout, 5):
        planner = sup.planner
        planner._bind(world)
        agents = world.active.nonzero()[0]
        if not len(agents):
            continue
        targets = planner.allowed_speed(world, agents)[:, None] * planner.fractions[None, :]
        s_proj = planner.project(world, agents, targets)
        for wild in (sup.uncontrolled, None):
            got = planner._domains_and_hold_lines(world, agents, s_proj, wild)
            want = reference_domains_and_hold_lines(planner, world, agents, s_proj, wild)
            np.testing.assert_array_equal(got[0], want[0])
            np.testing.assert_array_equal(got[1], want[1])
            held += int(np.isfinite(got[1]).sum())
        for turning_out in (None, world.is_car.copy()):
            np.testing.assert_array_equal(
                committed_crosswalks(world, world.front, turning_out),
                committed_crosswalks_numpy(world, world.front, turning_out),
            )
        checked += 1
    assert checked >= 100 and held > 0  # the comparison saw agents held at lines
