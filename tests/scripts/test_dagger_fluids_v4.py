"""scripts/checks/dagger_fluids_v4.py: the re-planned label equals the env's label where the ego
keeps no recovery path, and the summary pools training seeds with Wilson and bootstrap
intervals."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from script_module import load_script

import fluids_bench  # noqa: F401


@pytest.fixture(scope="module")
def ablation():
    return load_script("checks/dagger_fluids_v4.py")


def test_replanned_label_is_the_label_on_the_route(ablation):
    env = gym.make("FLUIDS-v4")
    _, info = env.reset(seed=2)
    for _ in range(10):  # each re-planned label builds a supervisor afresh: seconds per step
        assert not env.unwrapped.world.recovering[0]
        np.testing.assert_array_equal(
            ablation.replanned_label(env.unwrapped), info["supervisor_action"]
        )
        _, _, terminated, truncated, info = env.step(info["supervisor_action"])
        assert not (terminated or truncated)


def test_summary_pools_seeds(ablation):
    def row(seed, algo, wins):
        out = {
            "period": 1, "seed": seed, "algo": algo, "labels": 100,
            "success": [True] * wins + [False] * (4 - wins),
            "driving_score": [1.0] * wins + [0.2] * (4 - wins),
            "route_completion": [1.0] * 4, "steps": [10] * 4, "infractions": {"offroad": 4 - wins},
        }  # fmt: skip
        if algo == "dagger":
            out["probe"] = {"states": 40, "recovering": 4, "label_differs_from_replanned": 2}
        return out

    rows = [row(0, "bc", 4), row(1, "bc", 2), row(0, "dagger", 1), row(1, "dagger", 0)]
    out = ablation.summarise(rows)["1"]
    assert out["bc"]["episodes"] == 8 and out["bc"]["success_rate"] == 0.75
    assert out["bc"]["success_per_seed"] == [1.0, 0.5]
    assert out["bc"]["success_ci"][0] < 0.75 < out["bc"]["success_ci"][1]
    assert out["dagger"]["infractions"] == {"offroad": 7}
    assert out["dagger"]["probe"] == {
        "states": 80,
        "recovering": 8,
        "label_differs_from_replanned": 4,
    }
