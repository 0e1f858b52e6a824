"""Every registered id passes stable-baselines3's ``check_env`` without a warning (an RL user's
first check), except the ids listed below with the reason and the id to use instead.

MuJoCo ids keep Gymnasium's own spaces and are not checked here (unbounded observations are
theirs). Superseded versions keep their spaces bit for bit (datasets and published results are
built on them); their successor is checked instead. A new id is tested by being registered.
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import pytest
from train_extra import require_sb3

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.registration import ENV_SPECS

MUJOCO = "fluids_bench.tasks.locomotion."
# id -> (its successor that passes, why the id itself keeps a warning)
SUPERSEDED = {
    "FLUIDS-Sensitivity-v0": ("FLUIDS-Sensitivity-v2", "a [0, v_max] m/s action, (m, 4) rays"),
    "FLUIDS-Sensitivity-v1": ("FLUIDS-Sensitivity-v2", "a [0, v_max] m/s action, (m+1, 4) rays"),
    "GraspingInClutter-v0": ("GraspingInClutter-v1", "the gripper command in [0, 1]"),
}
IDS = sorted(i for i, (entry, _, _) in ENV_SPECS.items() if not entry.startswith(MUJOCO))
# the continuous levels of FLUIDS' RL-ready ids, beyond their registered defaults
LEVELS = [
    ("FLUIDS-v2", {"action_level": level}) for level in ("behavior", "trajectory", "velocity")
] + [("FLUIDS-v2", {"obs_type": "qlidar"}), ("FLUIDS-Sensitivity-v2", {"obs_type": "explicit"})]


def _warnings(env_id: str, **kwargs) -> list[str]:
    require_sb3()
    from stable_baselines3.common.env_checker import check_env

    env = gym.make(env_id, **kwargs)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    env.close()
    return [str(w.message) for w in caught]


@pytest.mark.train_extra
@pytest.mark.parametrize("env_id", [i for i in IDS if i not in SUPERSEDED])
def test_sb3_check_env_is_silent(env_id):
    assert _warnings(env_id) == []


@pytest.mark.train_extra
@pytest.mark.parametrize(("env_id", "kwargs"), LEVELS)
def test_sb3_check_env_is_silent_at_every_level_of_fluids_v2(env_id, kwargs):
    assert _warnings(env_id, **kwargs) == []


@pytest.mark.train_extra
@pytest.mark.parametrize("env_id", sorted(SUPERSEDED))
def test_superseded_ids_have_a_silent_successor(env_id):
    successor, _ = SUPERSEDED[env_id]
    assert successor in ENV_SPECS
    assert _warnings(env_id), f"{env_id} passes now: drop it from SUPERSEDED"


def test_grasping_v1_is_v0_with_the_gripper_command_shifted():
    """Same seed, same physical actions (v1's gripper command is 2g - 1): the same episode,
    and v1's label is v0's with its gripper entry shifted."""
    import numpy as np

    v0, v1 = gym.make("GraspingInClutter-v0"), gym.make("GraspingInClutter-v1")
    (o0, i0), (o1, i1) = v0.reset(seed=4), v1.reset(seed=4)
    for _ in range(40):
        a0 = i0["supervisor_action"]
        shifted = a0.copy()
        shifted[2] = 2.0 * a0[2] - 1.0
        assert np.array_equal(i1["supervisor_action"], shifted)
        o0, r0, t0, _, i0 = v0.step(a0)
        o1, r1, t1, _, i1 = v1.step(i1["supervisor_action"])
        assert np.array_equal(o0, o1) and r0 == r1 and t0 == t1
        if t0:
            break
