"""Every registered Gymnasium id works from TorchRL as a user writes it: ``GymEnv(id)`` (which
first probes the constructor with ``frameskip=`` and expects Python's ``TypeError``) passes
``check_env_specs`` and runs a short seeded rollout. A new id is tested by being registered."""

from __future__ import annotations

import pytest
from client_extra import require_client

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.registration import ENV_SPECS

INSTALL = "pip install torchrl==0.14.1"
pytestmark = pytest.mark.client_extra  # .ci/run's second phase runs it, with TorchRL


@pytest.mark.parametrize("env_id", sorted(ENV_SPECS))
def test_torchrl_gym_env_passes_check_env_specs(env_id):
    require_client("torchrl", INSTALL)
    from torchrl.envs import GymEnv
    from torchrl.envs.utils import check_env_specs

    env = GymEnv(env_id)
    assert env.wrapper_frame_skip == 1  # the probe's frameskip was dropped, not applied
    env.set_seed(0)
    check_env_specs(env, seed=0)  # resets and rolls out three steps, checking every spec
    rollout = env.rollout(5, break_when_any_done=False)
    assert rollout.batch_size[0] == 5
    env.close()
