"""Every environment id of the suite, in one place.

Kwargs stay JSON-friendly (numbers, strings, bools, lists) so that a dataset's stored env spec
rebuilds the same env. Bump the version suffix whenever an id's behaviour changes.
"""

from __future__ import annotations

import importlib
import warnings
from typing import Any

import gymnasium as gym
import pettingzoo

# The scene of the source's sensitivity analysis (ch. 7): the learner maps quasi-LIDAR to the
# ego's target velocity, the supervisor fills trajectory and control; success means every car
# arrived.
SENSITIVITY_SCENE: dict[str, Any] = {
    "action_level": "velocity",
    "obs_type": "qlidar",
    "num_cars": 3,
    "num_pedestrians": 2,
    "done_when": "all",
}
# v1, the fair benchmark: background drivers are defensive toward the ego (they keep the
# distance to stop for it, whatever it does); the quasi-LIDAR sees red lights, occupied
# crosswalks, the goal; success requires the ego not to run a red light nor drive onto an
# occupied crosswalk, and background cars wait for pedestrians on crosswalks
FAIR: dict[str, Any] = {
    "defensive": True,
    "lidar_version": 1,
    "obey_lights": True,
    "yield_to_pedestrians": True,
}
# v2: RL-ready v1 (same scenes, same success): normalised actions ([-1, 1] at every continuous
# level, labels in the same units), a reward that agrees with is_success, flat observations
# scaled to [-1, 1]; see the env card's Rewards and Version History
RL_READY: dict[str, Any] = {
    "action_scale": "normalized",
    "reward_version": 1,
    "obs_scale": "normalized",
}
# v3: v2 with its failure terms (collision, red light, failure to yield) weighted 3 instead of
# 1, so that at PPO's discount a policy that waits its turn is clearly worth more than one that
# rushes (measured on the docs' RL page)
RL_READY_V3: dict[str, Any] = {**RL_READY, "failure_penalty": 3.0}
# v4, the benchmark id for imitation and RL alike: v3's spaces and reward; the CARLA-style
# driving score in every episode's last info (time_limit = the step limit, so that a timeout is
# scored); the velocity planner at every step, so that the label is what a supervisor built
# afresh from the state gives (Markov labels); the learner acts at the trajectory level, where a
# random policy scores a small fraction of the supervisor's driving score (docs' FLUIDS page)
MARKOV_SCORED: dict[str, Any] = {"planner_period": 1, "driving_score": True}
BENCHMARK_V4: dict[str, Any] = {
    **RL_READY_V3,
    **MARKOV_SCORED,
    "action_level": "trajectory",
    "time_limit": 600,
}
# FLUIDS-v1's default scene is busy enough to discriminate: 8 walkers, and 60 s, which the
# yielding supervisor needs with them
BUSY_SCENE: dict[str, Any] = {"num_pedestrians": 8}
_FLUIDS = "fluids_bench.tasks.fluids.env:FluidsEnv"
# every id of the scalar FLUIDS env also has a native vector env: gym.make_vec(id, B,
# vectorization_mode="vector_entry_point") steps B worlds behind one VectorEnv
_FLUIDS_VECTOR = "fluids_bench.tasks.fluids.vector.workers:make_vector_env"
VECTOR_ENTRY_POINTS: dict[str, str] = {_FLUIDS: _FLUIDS_VECTOR}

# id -> (entry point, max_episode_steps, default kwargs)
ENV_SPECS: dict[str, tuple[str, int, dict[str, Any]]] = {
    "FLUIDS-v0": (_FLUIDS, 400, {}),
    # every car must arrive: longer than the ego alone needs
    "FLUIDS-Sensitivity-v0": (_FLUIDS, 600, dict(SENSITIVITY_SCENE)),
    "FLUIDS-v1": (_FLUIDS, 600, {**BUSY_SCENE, **FAIR}),
    "FLUIDS-Sensitivity-v1": (_FLUIDS, 600, {**SENSITIVITY_SCENE, **FAIR}),
    "FLUIDS-v2": (_FLUIDS, 600, {**BUSY_SCENE, **FAIR, **RL_READY}),
    "FLUIDS-Sensitivity-v2": (_FLUIDS, 600, {**SENSITIVITY_SCENE, **FAIR, **RL_READY}),
    "FLUIDS-v3": (_FLUIDS, 600, {**BUSY_SCENE, **FAIR, **RL_READY_V3}),
    "FLUIDS-Sensitivity-v3": (_FLUIDS, 600, {**SENSITIVITY_SCENE, **FAIR, **RL_READY_V3}),
    "FLUIDS-v4": (_FLUIDS, 600, {**BUSY_SCENE, **FAIR, **BENCHMARK_V4}),
    # the sensitivity analysis' scene keeps its velocity level (quasi-LIDAR -> target speed)
    "FLUIDS-Sensitivity-v4": (
        _FLUIDS,
        600,
        {**SENSITIVITY_SCENE, **FAIR, **RL_READY_V3, **MARKOV_SCORED, "time_limit": 600},
    ),
    "GridWorld-v0": ("fluids_bench.tasks.gridworld.env:GridWorldEnv", 30, {}),
    "DAG-v0": ("fluids_bench.tasks.dag.env:DAGEnv", 3, {}),
    # ch. 6: grasp the target among five obstacles; the supervisor needs ~30 steps
    "GraspingInClutter-v0": ("fluids_bench.tasks.grasping.env:GraspingInClutterEnv", 100, {}),
    # v1: the same task with a symmetric [-1, 1] action box (RL libraries' convention)
    "GraspingInClutter-v1": (
        "fluids_bench.tasks.grasping.env:GraspingInClutterEnv",
        100,
        {"action_scale": "normalized"},
    ),
    # Gymnasium's MuJoCo v5 locomotion envs with supervisors (ch. 3); 1,000 steps as in v5.
    "Hopper-IL-v0": ("fluids_bench.tasks.locomotion.env:HopperILEnv", 1000, {}),
    "Walker2d-IL-v0": ("fluids_bench.tasks.locomotion.env:Walker2dILEnv", 1000, {}),
    "HalfCheetah-IL-v0": ("fluids_bench.tasks.locomotion.env:HalfCheetahILEnv", 1000, {}),
    "Humanoid-IL-v0": ("fluids_bench.tasks.locomotion.env:HumanoidILEnv", 1000, {}),
    "Singulation-v0": ("fluids_bench.tasks.singulation.env:SingulationEnv", 150, {}),
    # ch. 6: two laps take ~180 steps; a crashed car is put back ahead, so it always progresses
    "DrivingTrack-v0": ("fluids_bench.tasks.track.env:DrivingTrackEnv", 600, {}),
    # the most crash-prone search (depth 1) as the stand-in for the source's imperfect supervisor
    "DrivingTrack-Source-v0": ("fluids_bench.tasks.track.env:DrivingTrackEnv", 600, {"depth": 1}),
}

# PettingZoo ParallelEnv ids, registered with PettingZoo's own registry:
# id -> (factory "module:function", default kwargs). Build with
# pettingzoo.make("parallel", id, **kwargs) or make_parallel_env(id, **kwargs). Factories take
# PettingZoo's ``max_cycles`` keyword (the registry tests shorten episodes with it).
_MULTI = "fluids_bench.tasks.fluids.multi_agent:parallel_env"
_MULTI_FAIR = {k: v for k, v in FAIR.items() if k != "obey_lights"}
PARALLEL_ENV_SPECS: dict[str, tuple[str, dict[str, Any]]] = {
    "FLUIDS-MultiAgent-v0": (_MULTI, {}),
    # (the multi-agent env has no obey_lights option: FAIR less that one)
    "FLUIDS-MultiAgent-v1": (_MULTI, dict(_MULTI_FAIR)),
    "FLUIDS-MultiAgent-v2": (_MULTI, {**_MULTI_FAIR, **RL_READY}),
    "FLUIDS-MultiAgent-v3": (_MULTI, {**_MULTI_FAIR, **RL_READY_V3}),
    # (its timeout is max_cycles)
    "FLUIDS-MultiAgent-v4": (
        _MULTI,
        {**_MULTI_FAIR, **RL_READY_V3, **MARKOV_SCORED, "action_level": "trajectory"},
    ),
}

# Steps each registry-driven test (tests/test_registry.py) runs per id. An id whose steps or
# construction are expensive may declare fewer here; every id still gets every check.
DEFAULT_TEST_STEPS = 20
TEST_STEPS: dict[str, int] = {}


def make_parallel_env(env_id: str, **kwargs: Any):
    """Build the PettingZoo ParallelEnv `env_id` of `PARALLEL_ENV_SPECS`."""
    if env_id not in PARALLEL_ENV_SPECS:
        raise ValueError(
            f"unknown parallel env id {env_id!r}; allowed: {sorted(PARALLEL_ENV_SPECS)}"
        )
    factory, defaults = PARALLEL_ENV_SPECS[env_id]
    module, _, name = factory.partition(":")
    return getattr(importlib.import_module(module), name)(**{**defaults, **kwargs})


def register_envs() -> None:
    """Register every id of `ENV_SPECS` with Gymnasium and every id of
    `PARALLEL_ENV_SPECS` with PettingZoo (idempotent)."""
    for env_id, (entry_point, max_steps, kwargs) in ENV_SPECS.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point=entry_point,
            max_episode_steps=max_steps,
            kwargs=dict(kwargs),
            vector_entry_point=VECTOR_ENTRY_POINTS.get(entry_point),
        )
    for env_id, (factory, kwargs) in PARALLEL_ENV_SPECS.items():
        if env_id in pettingzoo.parallel_registry:
            continue
        pettingzoo.register("parallel", env_id, entry_point=factory, kwargs=dict(kwargs))
    # Gymnasium warns "FLUIDS-v0 is out of date, consider v1" on every make. Here v0 and v1 are
    # not deprecated: v0 is the source's setting, kept bit-reproducible for the datasets and
    # sweeps built on it, v1 the fair-benchmark defaults in physical units (what IL datasets
    # record), v2 the RL-ready form that v3 reweights. Silence that advice for our ids only.
    superseded = "|".join(
        k
        for k in ENV_SPECS
        if k[-2:] in ("v0", "v1", "v2", "v3") and k[:-1] + str(int(k[-1]) + 1) in ENV_SPECS
    )
    warnings.filterwarnings(
        "ignore",
        message=rf".*The environment ({superseded}) is out of date",
        category=DeprecationWarning,
    )
