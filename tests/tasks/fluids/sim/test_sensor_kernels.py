"""The compiled quasi-LIDAR (``fluids_bench.tasks.fluids.sim.sensors.kernels``) against the numpy caster it
replaced (``qlidar_reference.py``): readings within the tolerance of ``tests/kernel_compare.py``
(ray directions and headings go through sin/cos), labels exactly.

States come from seeded FLUIDS-v0 episodes on every layout (several ray counts and ranges, the
ego and other agents as the observer) and from those states shuffled about at random, with
degenerate cases mixed in on purpose: agents on top of the observer (the ray origin inside a
rectangle), headings at multiples of π/2 (rays parallel to slabs and to axis-aligned kerbs),
the observer on a kerb segment's end or on a slab boundary, hits right at ``max_range``.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
import qlidar_reference as reference
from kernel_compare import assert_kernel_close

import fluids_bench  # noqa: F401  (registers the env ids)
from fluids_bench.tasks.fluids.sim.sensors.kernels import _maximum, _minimum
from fluids_bench.tasks.fluids.sim.sensors.qlidar import QLidarSensor, road_edges

LAYOUTS = ("four_way", "t_junction", "roundabout")


def assert_same(got: np.ndarray, want: np.ndarray, msg: str = "") -> None:
    """Readings (m, 4) within tolerance, their class labels (column 1) exactly."""
    assert_kernel_close(got, want, msg)
    np.testing.assert_array_equal(got[..., 1], want[..., 1], err_msg=msg)


def test_minimum_and_maximum_follow_numpy():
    special = [0.0, -0.0, 1.0, -1.0, math.inf, -math.inf, math.nan, 5e-324]
    for a in special:
        for b in special:
            for ours, theirs in ((_minimum, np.minimum), (_maximum, np.maximum)):
                got, want = ours(a, b), float(theirs(np.array([a]), np.array([b]))[0])
                if math.isnan(want):
                    assert math.isnan(got), (ours, a, b)
                else:
                    assert got == want and math.copysign(1, got) == math.copysign(1, want)


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize(("rays", "max_range"), [(64, 30.0), (7, 12.5), (181, 45.0)])
def test_cast_equals_reference_along_episodes(layout, rays, max_range):
    env = gym.make(
        "FLUIDS-v0", layout=layout, num_cars=6, num_pedestrians=4, obs_type="qlidar",
        lidar_rays=rays, lidar_range=max_range, action_level="velocity",
    )  # fmt: skip
    checked = 0
    for seed in (0, 1, 2):
        obs, info = env.reset(seed=seed)
        env.action_space.seed(seed)
        rng = np.random.default_rng(seed)
        world = env.unwrapped.world
        sensor = QLidarSensor(world.layout, rays, max_range)
        for step in range(120):
            # the env's own observation (agent 0, no noise) is the reference's, in float32
            assert_same(obs, reference.cast(world, 0, rays, max_range).astype(np.float32))
            for ego in range(0, len(world.state), 3):
                got = sensor.cast(world, ego)
                assert_same(
                    got, reference.cast(world, ego, rays, max_range), f"{seed} {step} {ego}"
                )
                checked += 1
            action = info["supervisor_action"] if rng.random() < 0.7 else env.action_space.sample()
            obs, _, term, trunc, info = env.step(action)
            if term or trunc:
                break
    assert checked > 300


def _jostle(world, rng: np.random.Generator, ego: int) -> None:
    """Move every agent somewhere random near the observer, with degenerate cases mixed in."""
    n = len(world.state)
    x0, y0, x1, y1 = world.layout.bounds
    edges = road_edges(world.layout)
    state = world.state
    state[:, 0] = rng.uniform(x0, x1, n)
    state[:, 1] = rng.uniform(y0, y1, n)
    state[:, 2] = rng.uniform(-2 * math.pi, 2 * math.pi, n)
    state[:, 3] = rng.uniform(-1.0, 12.0, n)
    world.active[:] = rng.random(n) < 0.8
    kind = rng.integers(6)
    if kind == 0:  # headings at multiples of π/2, positions on a coarse grid
        state[:, 2] = rng.integers(-4, 5, n) * (math.pi / 2)
        state[:, :2] = np.round(state[:, :2] * 2) / 2
    elif kind == 1:  # the observer on a kerb segment's start or midpoint
        i = rng.integers(len(edges.a))
        state[ego, :2] = edges.a[i] if rng.random() < 0.5 else edges.mid[i]
        state[ego, 2] = rng.choice([0.0, math.pi / 2, math.pi, -math.pi / 2, edges.angle[i]])
    elif kind == 2:  # other agents on top of the observer, or with a slab boundary through it
        state[ego, :2] = np.round(state[ego, :2] * 64) / 64  # so that the offsets below are exact
        state[ego, 2] = rng.choice([0.0, -0.0, math.pi / 2, state[ego, 2]])
        for j in rng.choice(n, size=min(n, 3), replace=False):
            heading = rng.choice([0.0, math.pi / 2, rng.uniform(-math.pi, math.pi)])
            along = rng.choice([0.0, world.length[j] / 2, -world.length[j] / 2, 0.3])
            across = rng.choice([0.0, world.width[j] / 2, -world.width[j] / 2])
            if heading == 0.0:  # axis-aligned: the ray origin exactly on a slab's boundary
                state[j] = (state[ego, 0] + along, state[ego, 1] + across, heading, state[j, 3])
            else:
                state[j, 2] = heading
                state[j, 0] = state[ego, 0] + along * math.cos(heading)
                state[j, 1] = state[ego, 1] + along * math.sin(heading)
    elif kind == 3:  # everything crowded within a few metres
        state[:, :2] = state[ego, :2] + rng.normal(0.0, 4.0, (n, 2))
    elif kind == 4:  # the observer axis-aligned at an integer point, others on the grid
        state[:, :2] = np.round(state[:, :2])
        state[ego, 2] = rng.integers(-2, 3) * (math.pi / 2)


@pytest.mark.parametrize("layout", LAYOUTS)
def test_cast_equals_reference_in_jostled_states(layout):
    env = gym.make("FLUIDS-v0", layout=layout, num_cars=8, num_pedestrians=4, obs_type="qlidar")
    env.reset(seed=11)
    world = env.unwrapped.world
    rng = np.random.default_rng(sum(map(ord, layout)))
    sensors = {
        (rays, max_range): QLidarSensor(world.layout, rays, max_range)
        for rays, max_range in [(1, 30.0), (4, 30.0), (64, 30.0), (64, 8.0), (100, 60.0)]
    }
    for case in range(400):
        ego = int(rng.integers(len(world.state)))
        _jostle(world, rng, ego)
        for (rays, max_range), sensor in sensors.items():
            assert_same(
                sensor.cast(world, ego),
                reference.cast(world, ego, rays, max_range),
                f"{layout} case {case} ego {ego} rays {rays} range {max_range}",
            )


def test_hit_exactly_at_max_range_reads_nothing():
    """A car whose near face is exactly ``max_range`` ahead is not seen, as in the reference."""
    env = gym.make("FLUIDS-v0", num_cars=2, num_pedestrians=1, obs_type="qlidar")
    env.reset(seed=0)
    world = env.unwrapped.world
    world.state[0] = (0.0, -1.75, 0.0, 1.0)
    world.active[:] = False
    world.active[:2] = True  # the ego and car 1
    half = world.length[1] / 2
    for gap in (10.0, 10.0 + 1e-9, 10.0 - 1e-9):
        world.state[1] = (gap + half, -1.75, 0.0, 2.0)
        sensor = QLidarSensor(world.layout, 16, 10.0)
        got = sensor.cast(world)
        assert_same(got, reference.cast(world, 0, 16, 10.0))
        assert (got[0, 1] == 1.0) == (gap < 10.0)


@pytest.mark.parametrize(("noise_var", "dropout"), [(0.0, 0.0), (0.3, 0.0), (0.0, 0.4), (0.3, 0.2)])
def test_observe_with_noise_equals_reference(noise_var, dropout):
    """Same generator state, same draws in the same order: the same float32 readings."""
    env = gym.make("FLUIDS-v0", num_cars=10, num_pedestrians=5, obs_type="qlidar")
    _, info = env.reset(seed=4)
    world = env.unwrapped.world
    sensor = QLidarSensor(world.layout, 64, 30.0, noise_var, dropout, max_speed=8.0)
    ours, theirs = np.random.default_rng(9), np.random.default_rng(9)
    for _ in range(40):
        for ego in (0, 5):
            want = reference.observe(world, theirs, ego, 64, 30.0, noise_var, dropout, 8.0)
            assert_same(sensor.observe(world, ours, ego), want)
        _, _, term, trunc, info = env.step(info["supervisor_action"])
        if term or trunc:
            break
    assert ours.random() == theirs.random()
