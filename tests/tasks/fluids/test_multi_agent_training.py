"""Multi-agent FLUIDS with existing tools: black-death semantics, SuperSuit, stable-baselines3."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from fluids_bench.registration import make_parallel_env
from fluids_bench.tasks.fluids.multi_agent import parallel_env

with warnings.catch_warnings():
    # importing pettingzoo.test loads PettingZoo's example envs through a deprecated API
    warnings.simplefilter("ignore", DeprecationWarning)
    from pettingzoo.test import parallel_api_test

import supersuit as ss  # test dependency (the `test` extra): the recipe's vectoriser
from train_extra import require_sb3


def test_black_death_passes_the_pettingzoo_api_test():
    env = parallel_env(controlled_cars=4, num_cars=1, black_death=True)
    parallel_api_test(env, num_cycles=60)


def test_multi_agent_v1_with_quasi_lidar_v1_passes_the_api_test():
    env = make_parallel_env(
        "FLUIDS-MultiAgent-v1", controlled_cars=3, num_cars=2, obs_type="qlidar", black_death=True
    )
    assert env.observation_space("car_0").shape == (65, 4)
    parallel_api_test(env, num_cycles=40)


def test_black_death_keeps_finished_agents_until_everyone_is_done():
    env = parallel_env(
        controlled_cars=3, num_cars=2, num_pedestrians=1, black_death=True, max_cycles=400
    )
    obs, infos = env.reset(seed=1)
    finished: dict[str, int] = {}
    steps = 0
    while env.agents:
        assert env.agents == env.possible_agents  # the set never shrinks mid-episode
        actions = {a: infos[a]["supervisor_action"] for a in env.agents}
        obs, rew, term, trunc, infos = env.step(actions)
        steps += 1
        for a in env.possible_agents:
            if a in finished and steps > finished[a] + 1 and env.agents:
                assert rew[a] == 0.0 and not term[a] and not trunc[a]
                assert not np.any(obs[a])  # zero observation once it has left
            if "is_success" in infos[a]:
                finished[a] = steps
    assert set(finished) == set(env.possible_agents)
    assert all(term.values())  # supervised: everyone arrived, all end in the same step
    assert steps == max(finished.values())


def test_black_death_truncates_the_unfinished_at_max_cycles():
    env = parallel_env(controlled_cars=3, black_death=True, max_cycles=30)
    env.reset(seed=0)
    stop = np.zeros(2, np.float32)
    stop[1] = -1.0  # brake: nobody arrives
    for _ in range(30):
        _, _, term, trunc, _ = env.step({a: stop for a in env.agents})
    assert not env.agents and all(trunc.values()) and not any(term.values())


def test_supersuit_vectorises_the_black_death_env():
    """SuperSuit 3.11's Markov vector env needs a fixed agent set: black death gives it one.
    Runs past several episode ends (auto-reset inside the vector env)."""
    env = parallel_env(
        controlled_cars=3, num_cars=1, black_death=True, max_cycles=40, action_level="velocity"
    )
    vec = ss.pettingzoo_env_to_vec_env_v1(env)
    vec = ss.concat_vec_envs_v1(vec, 2, num_cpus=0, base_class="gymnasium")
    assert vec.num_envs == 6  # 2 copies × 3 agents, one shared policy
    obs, _ = vec.reset(seed=0)
    assert obs.shape == (6, *env.observation_space("car_0").shape)
    rng = np.random.default_rng(0)
    ends = 0
    for _ in range(100):
        actions = rng.uniform(0, 10, (6, 1)).astype(np.float32)
        obs, rew, term, trunc, infos = vec.step(actions)
        assert obs.shape[0] == 6 and rew.shape == (6,)
        ends += int(np.sum(term | trunc))
    assert ends >= 6  # every agent's episode ended at least once


def test_without_black_death_supersuit_refuses_a_shrinking_agent_set():
    env = parallel_env(controlled_cars=2, max_cycles=400)
    vec = ss.pettingzoo_env_to_vec_env_v1(env)
    vec.reset(seed=0)
    with pytest.raises(AssertionError, match="black_death"):
        for _ in range(400):  # the first car to arrive or collide leaves `agents`
            vec.step(np.tile(np.array([0.0, 1.0], np.float32), (2, 1)))


@pytest.mark.train_extra
def test_shared_policy_recipe_trains_with_stable_baselines3(tmp_path):
    # the page's recipe, shortened; the optional `train` extra: skipped without it, except in CI
    # (FLUIDS_BENCH_TRAIN_TESTS=1)
    sb3 = require_sb3()
    from stable_baselines3.common.vec_env import VecMonitor

    from fluids_bench.core.pettingzoo_sb3 import shared_policy_vec_env

    env = make_parallel_env(
        "FLUIDS-MultiAgent-v2",
        controlled_cars=3,
        action_level="velocity",
        black_death=True,
        max_cycles=100,
    )
    vec = VecMonitor(shared_policy_vec_env(env, copies=2))
    model = sb3.PPO("MlpPolicy", vec, seed=0, n_steps=64, batch_size=64, n_epochs=1, verbose=0)
    model.learn(total_timesteps=768)
    model.save(tmp_path / "shared_policy")
    loaded = sb3.PPO.load(tmp_path / "shared_policy")
    obs, _ = env.reset(seed=5)
    action, _ = loaded.predict(obs["car_0"], deterministic=True)
    assert env.action_space("car_0").contains(np.asarray(action, np.float32))
