"""scripts/baselines/fluids_discount.py: one rollout gives both failure weights' returns, and
the discounted sum is taken with the given discount (tiny runs, the supervisor and an untrained
PPO model)."""

from __future__ import annotations

import json

import pytest
from script_module import load_script
from train_extra import require_sb3


def _module():
    return load_script("baselines/fluids_discount.py")


def test_supervisor_returns_do_not_depend_on_the_failure_weight_and_discounting_shrinks_them():
    fd = _module()
    row = fd.rollouts(lambda obs, env: env.unwrapped.supervisor_action(), 2, 0.99, 3.0)
    assert row["success_rate"] == 1.0  # it never fails, so both weights pay the same
    assert row["return"][0] == row["return"][1] >= 2.0
    assert 0 < row["discounted_return"][0] < row["return"][0]
    full = fd.rollouts(lambda obs, env: env.unwrapped.supervisor_action(), 2, 1.0, 3.0)
    assert full["discounted_return"] == full["return"]  # gamma 1: the plain sum


@pytest.mark.train_extra
def test_the_script_writes_every_policy_with_a_random_model(tmp_path):
    require_sb3()
    import gymnasium as gym
    from stable_baselines3 import PPO

    env = gym.make("FLUIDS-v2", action_level="velocity")
    path = tmp_path / "model.zip"
    PPO("MlpPolicy", env, seed=0, device="cpu").save(path)
    out = tmp_path / "discount.json"
    _module().main(["--models", f"untrained={path}", "--episodes", "1", "--out", str(out)])
    data = json.loads(out.read_text())
    assert set(data["policies"]) == {"supervisor", "untrained"}
    assert data["penalties"] == [1.0, 3.0] and data["gamma"] == 0.99
    row = data["policies"]["untrained"]
    assert row["return"][1] <= row["return"][0]  # a heavier failure weight never pays more
