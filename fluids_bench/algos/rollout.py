"""The one rollout function every algorithm, evaluation and script uses.

`rollout(env, actor, seed)` resets the env with `seed`, lets `actor` choose every action
and records the trajectory with the supervisor's label of every visited state. The actor's own
randomness comes from a generator derived from the same seed (a separate stream from the
env's), so one seed fixes the whole episode. Everything about an episode is in its arguments,
which is what a parallel collector needs to replace this loop later.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from fluids_bench.algos.actors import Actor
from fluids_bench.algos.dataset import Trajectory
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY, supervisor_action

# second entropy word of the actor's generator: keeps its stream apart from the env's
ACTOR_STREAM = 0xAC7


def actor_rng(seed: int) -> np.random.Generator:
    """The generator an actor uses during the episode with `seed`."""
    return np.random.default_rng([seed, ACTOR_STREAM])


def _label(env: gym.Env[Any, Any], info: dict[str, Any]) -> Any:
    if SUPERVISOR_ACTION_KEY in info:
        return info[SUPERVISOR_ACTION_KEY]
    return supervisor_action(env)  # raises a clear TypeError for envs without a supervisor


def rollout(
    env: gym.Env[Any, Any], actor: Actor, seed: int, max_steps: int | None = None
) -> Trajectory:
    """Run one episode from `env.reset(seed=seed)` until it ends (or `max_steps` steps)."""
    observation, info = env.reset(seed=seed)
    rng = actor_rng(seed)
    observations, actions, labels, rewards, infos = [observation], [], [], [], [info]
    terminated = truncated = False
    while not (terminated or truncated):
        if max_steps is not None and len(actions) >= max_steps:
            break
        label = _label(env, info)
        action = actor(observation, label, rng)
        observation, reward, terminated, truncated, info = env.step(action)
        observations.append(observation)
        actions.append(action)
        labels.append(label)
        rewards.append(float(reward))
        infos.append(info)
    return Trajectory(
        observations=np.stack(observations),
        actions=np.asarray(actions),
        labels=np.asarray(labels),
        rewards=np.asarray(rewards, dtype=np.float64),
        infos=infos,
        terminated=bool(terminated),
        truncated=bool(truncated),
        seed=seed,
    )
