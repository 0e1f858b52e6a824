"""The compiled defensive constraints against the numpy formulation they replaced
(``defensive_reference.py``). The result is boolean and compared exactly: the kernel's
arithmetic is the reference's except the C library's sin/cos in the agents' relative positions,
which only feed ahead/behind and aligned tests (see ``tests/kernel_compare.py``).

States come from seeded FLUIDS-v1 episodes (defensive supervisor, an uncontrolled ego that
the learner drives by noisy labels) on three layouts, and from the same states with agents
jostled, so that giving way, followers and stuck agents all occur.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from defensive_reference import reference_defensive_domains

import fluids_bench  # noqa: F401  (registers the ids)


def _plan_inputs(env):
    """The defensive call's inputs as plan() builds them, for the env's current state."""
    u = env.unwrapped
    world, sup = u.world, u.supervisor
    planner = sup.planner
    planner._bind(world)
    agents = world.active.nonzero()[0]
    wild = sup.uncontrolled[agents]
    targets = planner.allowed_speed(world, agents)[:, None] * planner.fractions[None, :]
    s_proj = planner.project(world, agents, targets)
    _, hold = planner._domains_and_hold_lines(world, agents, s_proj, sup.uncontrolled)
    return planner, world, agents, targets, wild, hold


def _states(layout: str, seed: int):
    env = gym.make("FLUIDS-v1", layout=layout, num_cars=8, num_pedestrians=4)
    rng = np.random.default_rng(seed)
    _, info = env.reset(seed=seed)
    for step in range(300):
        action = info["supervisor_action"] + rng.normal(0.0, 0.3, 2)
        _, _, term, trunc, info = env.step(np.clip(action, -1.0, 1.0).astype(np.float32))
        if term or trunc:
            _, info = env.reset(seed=seed + 1000 + step)
        if step % 3 == 0:
            yield _plan_inputs(env)
        if step % 15 == 7:  # jostle a copy: near misses, odd headings, agents inside clearance
            world = env.unwrapped.world
            saved = world.state.copy()
            world.state[:, :3] += rng.normal(0.0, [1.5, 1.5, 0.4], (world.n, 3))
            world.state[:, 3] = rng.uniform(0.0, 8.0, world.n)
            yield _plan_inputs(env)
            world.state[:] = saved


@pytest.mark.parametrize("layout", ["four_way", "t_junction", "roundabout"])
def test_defensive_kernel_equals_the_numpy_reference(layout):
    checked = pruned = 0
    for planner, world, agents, targets, wild, hold in _states(layout, 3):
        if not wild.any():
            continue
        for lines in (hold, None):
            got = planner.defensive_domains(world, agents, targets, wild, lines)
            want = reference_defensive_domains(planner, world, agents, targets, wild, lines)
            np.testing.assert_array_equal(got, want)
            pruned += int((~got).sum())
        checked += 1
    assert checked >= 50 and pruned > 0  # the comparison saw candidates pruned
