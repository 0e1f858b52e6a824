"""Every environment id of the suite, in one place.

Kwargs stay JSON-friendly (numbers, strings, bools, lists) so that a dataset's stored env spec
rebuilds the same env. Bump the version suffix whenever an id's behaviour changes.
"""

from __future__ import annotations

import importlib
from typing import Any

import gymnasium as gym

# id -> (entry point, max_episode_steps, default kwargs)
ENV_SPECS: dict[str, tuple[str, int, dict[str, Any]]] = {
    "FLUIDS-v0": ("fluids_bench.tasks.fluids.env:FluidsEnv", 400, {}),
    # The configuration of the source's sensitivity analysis (ch. 7): the learner maps
    # quasi-LIDAR to the ego's target velocity, the supervisor fills trajectory and control;
    # success means every car arrived.
    "FLUIDS-Sensitivity-v0": (
        "fluids_bench.tasks.fluids.env:FluidsEnv",
        600,  # every car must arrive: longer than the ego alone needs
        {
            "action_level": "velocity",
            "obs_type": "qlidar",
            "num_cars": 3,
            "num_pedestrians": 2,
            "done_when": "all",
        },
    ),
    # v1: background drivers are defensive toward the ego (they keep the distance to stop for
    # it, whatever it does); the quasi-LIDAR sees red lights, occupied crosswalks, the goal;
    # success requires the ego not to run a red light
    "FLUIDS-v1": (
        "fluids_bench.tasks.fluids.env:FluidsEnv",
        400,
        {"defensive": True, "lidar_version": 1, "obey_lights": True},
    ),
    "FLUIDS-Sensitivity-v1": (
        "fluids_bench.tasks.fluids.env:FluidsEnv",
        600,
        {
            "action_level": "velocity",
            "obs_type": "qlidar",
            "num_cars": 3,
            "num_pedestrians": 2,
            "done_when": "all",
            "defensive": True,
            "lidar_version": 1,
            "obey_lights": True,
        },
    ),
    "GridWorld-v0": ("fluids_bench.tasks.gridworld.env:GridWorldEnv", 30, {}),
    "DAG-v0": ("fluids_bench.tasks.dag.env:DAGEnv", 3, {}),
}

# PettingZoo ParallelEnv ids (not Gymnasium envs, so not registered with gym):
# id -> (factory "module:function", default kwargs); build with make_parallel_env(id, **kwargs)
PARALLEL_ENV_SPECS: dict[str, tuple[str, dict[str, Any]]] = {
    "FLUIDS-MultiAgent-v0": ("fluids_bench.tasks.fluids.multi_agent:parallel_env", {}),
    "FLUIDS-MultiAgent-v1": (
        "fluids_bench.tasks.fluids.multi_agent:parallel_env",
        {"defensive": True, "lidar_version": 1},
    ),
}


def make_parallel_env(env_id: str, **kwargs: Any):
    """Build the PettingZoo ParallelEnv ``env_id`` of :data:`PARALLEL_ENV_SPECS`."""
    if env_id not in PARALLEL_ENV_SPECS:
        raise ValueError(
            f"unknown parallel env id {env_id!r}; allowed: {sorted(PARALLEL_ENV_SPECS)}"
        )
    factory, defaults = PARALLEL_ENV_SPECS[env_id]
    module, _, name = factory.partition(":")
    return getattr(importlib.import_module(module), name)(**{**defaults, **kwargs})


def register_envs() -> None:
    """Register every id of :data:`ENV_SPECS` with Gymnasium (idempotent)."""
    for env_id, (entry_point, max_steps, kwargs) in ENV_SPECS.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point=entry_point,
            max_episode_steps=max_steps,
            kwargs=dict(kwargs),
        )
