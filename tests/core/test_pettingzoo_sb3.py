"""The PettingZoo -> stable-baselines3 shared-policy VecEnv (SuperSuit underneath)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import supersuit as ss  # test dependency (the `test` extra)
from train_extra import require_sb3

from fluids_bench.core.pettingzoo_sb3 import shared_policy_vec_env
from fluids_bench.registration import make_parallel_env

RENDER_MODE_WARNING = "render_mode` attribute is not defined"


def _env(max_cycles=50):
    return make_parallel_env(
        "FLUIDS-MultiAgent-v2", controlled_cars=3, num_cars=1, action_level="velocity",
        black_death=True, max_cycles=max_cycles,
    )  # fmt: skip


def _render_mode_warnings(build) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        build()
    return [str(w.message) for w in caught if RENDER_MODE_WARNING in str(w.message)]


@pytest.mark.train_extra
def test_supersuits_own_sb3_path_warns_about_render_mode():
    # the defect the helper exists for; if SuperSuit fixes it, this fails and the helper can go
    sb3 = require_sb3()
    vec = ss.concat_vec_envs_v1(
        ss.pettingzoo_env_to_vec_env_v1(_env()), 2, num_cpus=0, base_class="stable_baselines3"
    )
    assert _render_mode_warnings(lambda: sb3.common.vec_env.VecMonitor(vec))


@pytest.mark.train_extra
def test_recipe_with_the_helper_emits_no_render_mode_warning_and_trains():
    sb3 = require_sb3()
    from stable_baselines3.common.vec_env import VecMonitor

    vec = shared_policy_vec_env(_env(), copies=2)
    assert vec.num_envs == 6 and vec.render_mode is None

    def build():
        model = sb3.PPO("MlpPolicy", VecMonitor(vec), seed=0, n_steps=32, batch_size=64, n_epochs=1)
        model.learn(total_timesteps=192)

    assert _render_mode_warnings(build) == []


@pytest.mark.train_extra
def test_seed_gives_the_same_first_observations_and_another_seed_others():
    require_sb3()
    a, b, c = (shared_policy_vec_env(_env(), copies=2) for _ in range(3))
    a.seed(3)
    b.seed(3)
    c.seed(4)
    first_a, first_b, first_c = a.reset(), b.reset(), c.reset()
    assert first_a.shape == (6, *_env().observation_space("car_0").shape)
    np.testing.assert_array_equal(first_a, first_b)
    assert not np.array_equal(first_a, first_c)
    actions = np.zeros((6, 1), np.float32)
    np.testing.assert_array_equal(a.step(actions)[0], b.step(actions)[0])


@pytest.mark.parametrize("copies", [0, -1, 1.5, True, "2"])
def test_copies_must_be_a_positive_int(copies):
    with pytest.raises(ValueError, match="copies must be an int >= 1"):
        shared_policy_vec_env(_env(), copies=copies)
