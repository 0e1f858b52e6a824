"""The shipped supervisors do their job: a small seeded sample of the README's quality table.

The full table (10 seeded 1,000-step episodes per id) is made by
scripts/quality/locomotion_supervisor_quality.py; here a few episodes check that the shipped weights
still walk (a broken file, a changed observation or a wrong hash would fail these).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.tasks.locomotion.supervisors import load_policy, manifest


def supervised_return(
    env: gym.Env, seed: int, steps: int, noise_std: float = 0.0
) -> tuple[float, bool]:
    """Return and fall of one episode that executes the label, plus N(0, noise_std^2 I) clipped
    to the action space when noise_std > 0 (how noise-injection methods collect)."""
    rng = np.random.default_rng([seed, 0xA5])
    _, info = env.reset(seed=seed)
    total = 0.0
    for _ in range(steps):
        action = info["supervisor_action"]
        if noise_std:
            action = action + noise_std * rng.standard_normal(action.shape)
            action = np.clip(action, env.action_space.low, env.action_space.high)
        _, reward, terminated, truncated, info = env.step(action)
        total += reward
        if terminated or truncated:
            return total, terminated
    return total, False


def test_every_shipped_weight_file_matches_its_recorded_hash():
    assert manifest(), "no shipped weights"
    for task, record in manifest().items():
        policy, _ = load_policy(task)  # raises if the bytes do not hash to the record
        assert policy.obs_dim == gym.make(f"{task}-v5").observation_space.shape[0]
        assert record["recipe"]["seed"] is not None and record["sha256"]


def test_hopper_policy_hops_without_falling():
    """Shipped Hopper policy: 3 seeded 1,000-step episodes, no fall, mean return >= 2,500
    (the README reports 10 episodes)."""
    env = gym.make("Hopper-IL-v0", supervisor="policy")
    results = [supervised_return(env, seed, 1000) for seed in range(3)]
    assert not any(fell for _, fell in results)
    assert np.mean([r for r, _ in results]) >= 2500


def test_walker2d_policy_walks_above_the_floor_without_falling():
    """Shipped Walker2d policy: 3 seeded 1,000-step episodes, no fall, mean >= 4,000 (the
    issue's floor; the quality table's 10 episodes: 4,227 ± 24)."""
    env = gym.make("Walker2d-IL-v0", supervisor="policy")
    results = [supervised_return(env, seed, 1000) for seed in range(3)]
    assert not any(fell for _, fell in results)
    assert np.mean([r for r, _ in results]) >= 4000


def test_halfcheetah_policy_runs_upright_above_the_floor():
    """Shipped HalfCheetah policy: 3 seeded 1,000-step episodes, mean >= 4,400 (the issue's
    floor; the quality table's 10 episodes: 5,115 ± 30), never on its back."""
    env = gym.make("HalfCheetah-IL-v0", supervisor="policy")
    returns = []
    for seed in range(3):
        _, info = env.reset(seed=seed)
        total, pitch = 0.0, 0.0
        for _ in range(1000):
            _, reward, _, _, info = env.step(info["supervisor_action"])
            total += reward
            pitch = max(pitch, abs(env.unwrapped._sim.data.qpos[2]))
        returns.append(total)
        assert pitch < np.pi / 2
    assert np.mean(returns) >= 4400


def test_humanoid_policy_walks_above_the_floor():
    """Shipped Humanoid policy: seeds 0-2, 1,000 steps, mean >= 5,000 (the issue's floor; the
    quality table's 10 episodes: 7,125 ± 19, no falls). Its first labels are its own forward
    pass on Gymnasium's 348-entry observation."""
    env = gym.make("Humanoid-IL-v0")
    assert env.unwrapped.metadata["supervisor"]["kind"] == "policy"
    results = [supervised_return(env, seed, 1000) for seed in range(3)]
    assert np.mean([r for r, _ in results]) >= 5000


@pytest.mark.slow
def test_halfcheetah_mpc_runs_forward():
    """The cold-start planner, 100 steps of one seed: it runs forward, upright (random actions
    make about -28 in 100 steps)."""
    env = gym.make("HalfCheetah-IL-v0", supervisor="mpc")
    total, _ = supervised_return(env, 0, 100)
    assert total > 50.0
    assert abs(env.unwrapped._sim.data.qpos[2]) < 1.0  # not flipped onto its back


@pytest.mark.parametrize("task", ["Hopper", "Walker2d", "HalfCheetah", "Humanoid"])
def test_shipped_teacher_tolerates_the_noise_dart_injects(task):
    """The noise target at sigma = 0.05 on a sample of 3 seeds (the quality table has 10, the
    issue's check 60 unseen): executed-action noise keeps >= 90 % of the clean return on the
    same seeds, and no episode falls. A teacher trained without noise fails this (the Humanoid
    before its noise stages fell in every episode at this sigma)."""
    env = gym.make(f"{task}-IL-v0", supervisor="policy")
    clean = [supervised_return(env, seed, 1000)[0] for seed in range(3)]
    noisy = [supervised_return(env, seed, 1000, noise_std=0.05) for seed in range(3)]
    assert not any(fell for _, fell in noisy)
    assert np.mean([r for r, _ in noisy]) >= 0.9 * np.mean(clean)
