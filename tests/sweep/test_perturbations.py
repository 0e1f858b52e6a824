"""The tasks' perturbation kwargs (a sensitivity sweep's factors): the defaults give the same
episodes as before (written out explicitly they change nothing), other values change the
world, and bad values are refused naming the field."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import fluids_bench  # noqa: F401
from fluids_bench.algos.actors import SUPERVISOR
from fluids_bench.algos.rollout import rollout

CASES = [
    # id, the defaults written out, a perturbation, steps
    ("Singulation-v0", {"mass_ratio": 1.0, "friction_scale": 1.0}, {"friction_scale": 0.2}, 40),
    ("Singulation-v0", {"object_size_scale": 1.0}, {"object_size_scale": 1.2}, 40),
    (
        "GraspingInClutter-v0",
        {"obstacle_size_scale": 1.0, "friction": 0.5, "obstacles": 5},
        {"obstacle_size_scale": 1.25},
        20,
    ),
    ("GraspingInClutter-v0", {"obstacles": 5}, {"obstacles": 2}, 20),
    (
        "DrivingTrack-v0",
        {"edges": None, "obs_noise": 0.0, "obs_type": "state"},
        {"edges": 3, "obs_type": "state"},
        20,
    ),
    (
        "Hopper-IL-v0",
        {
            "body_mass_scale": 1.0,
            "friction_scale": 1.0,
            "actuator_gain_scale": 1.0,
            "gravity": 9.81,
            "obs_noise": 0.0,
            "action_noise": 0.0,
        },
        {"actuator_gain_scale": 0.5},
        30,
    ),
    ("FLUIDS-v0", {"pedestrian_speed": 1.4, "light_cycle_scale": 1.0}, {"pedestrian_speed": 3}, 40),
]


def _episode(env_id, kwargs, steps):
    env = gym.make(env_id, **kwargs)
    trajectory = rollout(env, SUPERVISOR, 7, max_steps=steps)
    env.close()
    return trajectory


@pytest.mark.parametrize("env_id, defaults, perturbed, steps", CASES)
def test_defaults_are_the_nominal_env_and_perturbations_change_it(
    env_id, defaults, perturbed, steps
):
    base = {"obs_type": defaults["obs_type"]} if "obs_type" in defaults else {}
    nominal = _episode(env_id, base, steps)
    explicit = _episode(env_id, defaults, steps)
    np.testing.assert_array_equal(nominal.observations, explicit.observations)
    np.testing.assert_array_equal(nominal.labels, explicit.labels)
    changed = _episode(env_id, perturbed, steps)
    n = min(len(changed), len(nominal))
    assert not np.array_equal(changed.observations[:n], nominal.observations[:n])


@pytest.mark.parametrize(
    "env_id, kwargs, field",
    [
        ("Singulation-v0", {"mass_ratio": 0.5}, "mass_ratio"),
        ("Singulation-v0", {"friction_scale": -1.0}, "friction_scale"),
        ("Singulation-v0", {"object_size_scale": 2.0}, "object_size_scale"),
        ("GraspingInClutter-v0", {"obstacle_size_scale": 2.0}, "obstacle_size_scale"),
        ("GraspingInClutter-v0", {"friction": "high"}, "friction"),
        ("GraspingInClutter-v0", {"obstacles": 6}, "obstacles"),
        ("DrivingTrack-v0", {"edges": 12}, "edges"),
        ("DrivingTrack-v0", {"obs_noise": float("nan")}, "obs_noise"),
        ("Hopper-IL-v0", {"gravity": -9.81}, "gravity"),
        ("Walker2d-IL-v0", {"body_mass_scale": 0.0}, "body_mass_scale"),
        ("HalfCheetah-IL-v0", {"action_noise": -0.1}, "action_noise"),
        ("FLUIDS-v0", {"light_cycle_scale": 10}, "light_cycle_scale"),
        ("FLUIDS-v1", {"pedestrian_speed": 0}, "pedestrian_speed"),
    ],
)
def test_bad_perturbations_name_the_field(env_id, kwargs, field):
    with pytest.raises(ValueError, match=f"field '{field}'"):
        gym.make(env_id, **kwargs)


def test_locomotion_noise_is_seeded_and_the_label_sees_the_true_state():
    kwargs = {"obs_noise": 0.1, "action_noise": 0.1}
    a, b = _episode("Hopper-IL-v0", kwargs, 20), _episode("Hopper-IL-v0", kwargs, 20)
    np.testing.assert_array_equal(a.observations, b.observations)
    env = gym.make("Hopper-IL-v0", obs_noise=0.5)
    obs, info = env.reset(seed=3)
    nominal = gym.make("Hopper-IL-v0")
    obs0, info0 = nominal.reset(seed=3)
    np.testing.assert_array_equal(info["supervisor_action"], info0["supervisor_action"])
    assert not np.array_equal(obs, obs0)
