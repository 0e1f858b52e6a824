"""Malformed actions are refused with a ValueError naming the level (and, multi-agent, the agent)
and the allowed form; they are never silently coerced."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import fluids_bench  # noqa: F401
from fluids_bench.tasks.fluids.multi_agent import parallel_env

NOT_REAL = [
    "0.5",
    ["0.5", "0.1"],
    np.array(["0.5", "0.1"]),
    np.array([0.5 + 1j, 0.0]),
    [1j, 0],
    np.array([True, False]),
    [True, False],
    True,
    [None, 0.1],
]


@pytest.mark.parametrize("level", ["trajectory", "velocity", "control"])
@pytest.mark.parametrize("action", NOT_REAL, ids=repr)
def test_box_actions_that_are_not_real_numbers_are_refused(level, action):
    env = gym.make("FLUIDS-v0", action_level=level, num_cars=0, num_pedestrians=0)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=rf"{level} action is .*allowed: an array of \d+ real"):
        env.step(action)


def test_integer_and_float_box_actions_still_work():
    env = gym.make("FLUIDS-v0", action_level="velocity", num_cars=0, num_pedestrians=0)
    env.reset(seed=0)
    for action in ([3], np.array([3], np.int64), np.array([3.0], np.float32), [np.float64(3.0)]):
        env.step(action)


@pytest.mark.parametrize("action", ["1", 1.0, True, np.array([True]), 1j])
def test_behavior_actions_must_be_integers(action):
    env = gym.make("FLUIDS-v0", action_level="behavior", num_cars=0, num_pedestrians=0)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="behavior action is .*allowed: an integer in"):
        env.step(action)


@pytest.mark.parametrize("actions", [None, [np.zeros(2, np.float32)], "car_0", 3])
def test_multi_agent_actions_must_be_a_dict(actions):
    env = parallel_env(controlled_cars=2)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions is .*allowed: a dict from agent name"):
        env.step(actions)


def test_multi_agent_bad_action_names_the_agent():
    env = parallel_env(controlled_cars=3)
    env.reset(seed=0)
    good = np.zeros(2, np.float32)
    for bad, what in (
        ("0.5", "real numbers"),
        (np.array([np.nan, 0.0]), "not finite"),
        (np.zeros(3), "shape"),
    ):
        with pytest.raises(ValueError, match=rf"car_2: control action .*{what}"):
            env.step({"car_0": good, "car_1": good, "car_2": bad})
