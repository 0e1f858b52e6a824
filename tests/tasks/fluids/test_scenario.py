"""The scenario shared by FLUIDS-v0 and the multi-agent env: one meaning per reward and info field."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401
from fluids_bench.tasks.fluids.multi_agent import parallel_env

SCENE = {"num_cars": 3, "num_pedestrians": 0, "layout": "four_way"}


def _crash_background(world) -> None:
    """Background car 1 leaves the road far from everyone: a collision the ego is not part of."""
    world.state[1, :2] = (300.0, 300.0)


def _single(seed: int) -> tuple[list[float], dict]:
    env = gym.make("FLUIDS-v0", max_episode_steps=600, **SCENE)
    _, info = env.reset(seed=seed)
    _crash_background(env.unwrapped.world)
    rewards = []
    for step in range(600):
        _, r, term, trunc, info = env.step(info["supervisor_action"])
        rewards.append(r)
        if step == 0:
            assert any(c["a"] == 1 and c["kind"] == "offroad" for c in info["collisions"])
            env.unwrapped.world.active[1] = False  # the wreck leaves, as in the multi-agent env
        if term or trunc:
            return rewards, info
    raise AssertionError("episode did not end")


def _multi(seed: int) -> tuple[list[float], dict]:
    env = parallel_env(controlled_cars=1, max_cycles=600, **SCENE)
    _, infos = env.reset(seed=seed)
    _crash_background(env.world)
    rewards = []
    for step in range(600):
        _, r, term, trunc, infos = env.step({"car_0": infos["car_0"]["supervisor_action"]})
        rewards.append(r["car_0"])
        if step == 0:
            env.world.active[1] = False
        if term["car_0"] or trunc["car_0"]:
            return rewards, infos["car_0"]
    raise AssertionError("episode did not end")


def test_is_success_and_rewards_mean_the_same_in_both_envs():
    """The same scene, seed and actions in both envs: a collision between other agents does not
    make the controlled car's arrival a failure in either, and the rewards are the same."""
    for seed in (0, 1):
        r1, info1 = _single(seed)
        r2, info2 = _multi(seed)
        assert info1["ego_arrived"] and info2["arrived"]
        assert info1["is_success"] is True and info2["is_success"] is True
        np.testing.assert_array_equal(np.array(r1), np.array(r2, dtype=float))


def test_done_when_all_success_needs_every_car():
    env = gym.make("FLUIDS-v0", done_when="all", max_episode_steps=600, **SCENE)
    _, info = env.reset(seed=0)
    _crash_background(env.unwrapped.world)
    _, _, term, _, info = env.step(info["supervisor_action"])
    assert term and info["is_success"] is False
