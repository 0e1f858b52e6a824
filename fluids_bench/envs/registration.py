"""Every environment id of the suite, in one place.

Kwargs stay JSON-friendly (numbers, strings, bools, lists) so that a dataset's stored env spec
rebuilds the same env. Bump the version suffix whenever an id's behaviour changes.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

# id -> (entry point, max_episode_steps, default kwargs)
ENV_SPECS: dict[str, tuple[str, int, dict[str, Any]]] = {
    "FLUIDS-v0": ("fluids_bench.envs.fluids:FluidsEnv", 400, {}),
    # The configuration of the source's sensitivity analysis (ch. 7): the learner picks the
    # ego's target velocity, the supervisor fills trajectory and control.
    "FLUIDS-Sensitivity-v0": (
        "fluids_bench.envs.fluids:FluidsEnv",
        400,
        {"action_level": "velocity", "num_cars": 4, "num_pedestrians": 2},
    ),
    "GridWorld-v0": ("fluids_bench.envs.gridworld:GridWorldEnv", 30, {}),
    "DAG-v0": ("fluids_bench.envs.dag:DAGEnv", 3, {}),
}


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
