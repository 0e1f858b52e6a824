"""The per-task control mappings as pure functions (no window)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import fluids_bench  # noqa: F401
from fluids_bench.core import raster
from fluids_bench.human import controls as c


def test_gridworld_and_track_keys():
    assert c.gridworld_action(frozenset({"left"})) == 0
    assert c.gridworld_action(frozenset({"right"})) == 1
    assert c.gridworld_action(frozenset({"up"})) == 2
    assert c.gridworld_action(frozenset({"down"})) == 3
    assert c.gridworld_action(frozenset({"space"})) == 4
    assert c.gridworld_action(frozenset()) is None
    assert c.track_action(frozenset({"left"})) == 2  # +15 degrees, counter-clockwise
    assert c.track_action(frozenset({"right"})) == 0
    assert c.track_action(frozenset({"up"})) == 1
    assert c.track_action(frozenset({"left", "right"})) is None


def test_fluids_control_keys_and_stick():
    a = c.fluids_control_action(frozenset({"left", "up"}))
    assert a.tolist() == [0.5, 1.0]
    assert c.fluids_control_action(frozenset({"right", "shift", "down"})).tolist() == [-1.0, -1.0]
    # stick pushed right and up: steer right, accelerate; inside the dead zone: nothing
    np.testing.assert_allclose(c.fluids_control_action(frozenset(), (0.4, -0.6)), [-0.4, 0.6])
    assert c.fluids_control_action(frozenset(), (0.05, 0.05)).tolist() == [0.0, 0.0]


def test_fluids_velocity_target():
    assert c.fluids_velocity_target(0.0, "up", 10.0) == 1.0
    assert c.fluids_velocity_target(0.5, "down", 10.0) == 0.0
    assert c.fluids_velocity_target(3.0, "9", 10.0) == 10.0
    assert c.fluids_velocity_target(3.0, "x", 10.0) == 3.0
    assert c.fluids_velocity_from_stick((0.0, -1.0), 8.0) == 8.0
    assert c.fluids_velocity_from_stick((0.0, 0.0), 8.0) is None


def test_pixel_to_world_inverts_the_raster_affine():
    affine = raster.pixel_affine(250.0, -0.4, 0.8)
    u, v = affine @ np.array([0.1, 0.3, 1.0])
    assert c.pixel_to_world(u, v, 250.0, -0.4, 0.8) == pytest.approx((0.1, 0.3))


def test_singulation_and_grasping_actions():
    # the pointer straight along the arm, further out: extend only, saturated
    a = c.singulation_action((0.0, 0.5), math.pi / 2, 0.2, math.radians(1.5), 0.01)
    np.testing.assert_allclose(a, [0.0, 1.0], atol=1e-6)
    assert c.singulation_action(None, 1.0, 0.3, 0.02, 0.01).tolist() == [0.0, 0.0]
    g = c.grasping_action((1.0, 0.0), (0.0, 0.0), True, 0.025)
    np.testing.assert_allclose(g, [1.0, 0.0, 1.0])
    g = c.grasping_action((0.01, 0.0), (0.0, 0.0), False, 0.025)  # within a step: slower
    np.testing.assert_allclose(g, [0.4, 0.0, 0.0], rtol=1e-6)


@pytest.mark.parametrize(
    ("env_id", "kwargs", "scheme"),
    [
        ("GridWorld-v0", {}, c.GridWorldScheme),
        ("DrivingTrack-v0", {}, c.TrackScheme),
        ("Singulation-v0", {}, c.SingulationScheme),
        ("GraspingInClutter-v0", {}, c.GraspingScheme),
        ("FLUIDS-v1", {"num_pedestrians": 0}, c.FluidsControlScheme),
        ("FLUIDS-v1", {"action_level": "velocity", "num_pedestrians": 0}, c.FluidsVelocityScheme),
    ],
)
def test_every_teleop_family_has_a_scheme_whose_actions_fit(env_id, kwargs, scheme):
    env = gym.make(env_id, **kwargs)
    env.reset(seed=0)
    s = c.scheme_for(env)
    assert isinstance(s, scheme)
    for inputs in (c.Inputs(), c.Inputs(frozenset({"left"}), (10.0, 10.0), (True, False, True))):
        assert env.action_space.contains(s.action(inputs))
    env.close()


@pytest.mark.parametrize(
    ("env_id", "kwargs", "message"),
    [
        ("DAG-v0", {}, "DAG-v0 has no teleop mapping"),
        ("FLUIDS-v1", {"action_level": "behavior", "num_pedestrians": 0}, "no teleop mapping"),
    ],
)
def test_ids_without_a_mapping_are_refused(env_id, kwargs, message):
    env = gym.make(env_id, **kwargs)
    with pytest.raises(ValueError, match=message):
        c.scheme_for(env)
