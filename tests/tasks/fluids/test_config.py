"""`FluidsConfig`: one frozen dataclass of every FLUIDS option, shared by the scalar, vector and
multi-agent envs, with each field's description in its docstring."""

from __future__ import annotations

import dataclasses
import inspect

import gymnasium as gym
import numpy as np
import pytest

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS, make_parallel_env
from fluids_bench.tasks.fluids.config import (
    GROUPS,
    MULTI_AGENT,
    SINGLE_AGENT,
    FluidsConfig,
    field_docs,
)
from fluids_bench.tasks.fluids.env import FluidsEnv
from fluids_bench.tasks.fluids.multi_agent import FluidsParallelEnv

FIELDS = [f.name for f in dataclasses.fields(FluidsConfig)]


def test_every_field_has_a_group_and_a_description():
    assert set(field_docs()) == set(FIELDS)
    assert all(text.strip() for text in field_docs().values())
    assert {f.metadata["group"] for f in dataclasses.fields(FluidsConfig)} == set(GROUPS)
    config = FluidsConfig()
    assert [n for g in GROUPS for n in config.group(g)] == FIELDS  # declared group by group


def test_the_faces_take_what_they_took_and_name_it_in_their_signatures():
    only_multi = {"controlled_cars", "max_cycles", "black_death"}
    only_single = {"pedestrian_speed", "light_cycle_scale", "done_when", "obey_lights",
                   "end_on_violation", "time_limit"}  # fmt: skip
    assert set(SINGLE_AGENT.options) == set(FIELDS) - only_multi
    assert set(MULTI_AGENT.options) == set(FIELDS) - only_single
    for face, cls in ((SINGLE_AGENT, FluidsEnv), (MULTI_AGENT, FluidsParallelEnv)):
        params = inspect.signature(cls).parameters
        assert list(params) == [*face.options, "render_mode"]
        assert all(params[n].default == face.default(n) for n in face.options)
    assert MULTI_AGENT.default("num_cars") == 0 and SINGLE_AGENT.default("num_cars") == 3


def test_registered_versions_are_presets_of_the_config():
    for entry, _, kwargs in ENV_SPECS.values():
        if entry.endswith(":FluidsEnv"):
            assert set(kwargs) <= set(SINGLE_AGENT.options), entry
    for entry, kwargs in PARALLEL_ENV_SPECS.values():
        assert set(kwargs) <= set(MULTI_AGENT.options), entry


def test_each_env_holds_its_checked_config():
    env = gym.make("FLUIDS-v3", num_cars=np.int64(2), obs_type=["explicit", "qlidar"])
    config = env.unwrapped.config
    assert isinstance(config, FluidsConfig)
    assert config.failure_penalty == 3.0 and config.lidar_version == 1
    assert type(config.num_cars) is int and config.obs_type == ("explicit", "qlidar")
    assert env.unwrapped.num_cars == 2 and env.unwrapped.failure_penalty == 3.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.num_cars = 4
    multi = make_parallel_env("FLUIDS-MultiAgent-v1", controlled_cars=2)
    assert multi.config.controlled_cars == 2 and multi.config.defensive
    vec = gym.make_vec("FLUIDS-v1", 2, vectorization_mode="vector_entry_point", num_cars=1)
    assert vec.unwrapped.config == gym.make("FLUIDS-v1", num_cars=1).unwrapped.config
    vec.close()
    kwargs = {"vectorization_mode": "vector_entry_point", "num_workers": 2, "num_cars": 1}
    workers = gym.make_vec("FLUIDS-v1", 2, **kwargs)
    assert workers.unwrapped.config == vec.unwrapped.config
    workers.close()


def test_errors_name_the_env_or_the_config():
    with pytest.raises(ValueError, match=r"^FluidsEnv: field 'lidar_rays' is 0"):
        gym.make("FLUIDS-v0", lidar_rays=0)
    with pytest.raises(ValueError, match=r"^FluidsParallelEnv: field 'max_cycles' is 0"):
        make_parallel_env("FLUIDS-MultiAgent-v0", max_cycles=0)
    with pytest.raises(ValueError, match=r"^FluidsConfig: field 'failure_penalty' is 3.0"):
        FluidsConfig(failure_penalty=3.0)  # only with reward_version=1
    config = dataclasses.replace(FluidsConfig(reward_version=1), failure_penalty=3.0)
    assert config.failure_penalty == 3.0
    with pytest.raises(ValueError, match="field 'dt'"):
        dataclasses.replace(config, dt=1.0)
