"""The behaviour-level label is the movement the supervisor sampled for the car, never an echo of
the learner's own previous action."""

from __future__ import annotations

import gymnasium as gym

import fluids_bench  # noqa: F401
from fluids_bench.tasks.fluids.multi_agent import parallel_env


def test_a_contrary_behavior_policy_never_agrees_with_its_labels():
    env = gym.make("FLUIDS-v0", action_level="behavior")
    n = env.action_space.n
    for seed in range(3):
        _, info = env.reset(seed=seed)
        sampled = info["supervisor_action"]
        route_at_start = info["route"]
        for step in range(30):
            label = info["supervisor_action"]
            assert label == sampled, (seed, step)  # the learner's choice does not move it
            action = (label + 1) % n  # always another movement than the label
            _, _, term, trunc, info = env.step(action)
            assert info["supervisor_action"] != action, (seed, step)
            assert info["supervisor_action"] == env.unwrapped.supervisor_action()
            if term or trunc:
                break
        assert info["route"] != route_at_start  # the learner did change the car's route


def test_multi_agent_behavior_labels_do_not_echo_the_agents():
    env = parallel_env(controlled_cars=4, action_level="behavior", max_cycles=20)
    _, infos = env.reset(seed=1)
    sampled = {a: i["supervisor_action"] for a, i in infos.items()}
    n = env.action_space("car_0").n
    while env.agents:
        actions = {a: (infos[a]["supervisor_action"] + 1) % n for a in env.agents}
        _, _, _, _, infos = env.step(actions)
        for agent, info in infos.items():
            assert info["supervisor_action"] == sampled[agent] != actions[agent]
