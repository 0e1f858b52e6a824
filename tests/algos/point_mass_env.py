"""A tiny continuous-action env for the algorithm tests: a 2-D point mass and a P-controller.

Box observation (position, m), Box action (velocity command in [-1, 1]^2, m/s), dt = 0.5 s and
a little Gaussian drift, so that errors compound. The supervisor is proportional:
``u* = clip(-gain * x, -1, 1)``. Reward ``exp(-|x|^2)`` is positive, so normalised performance
is defined.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY

ENV_ID = "PointMassTest-v0"
DT = 0.5
DRIFT_STD = 0.05


class PointMassEnv(gym.Env[np.ndarray, np.ndarray]):
    def __init__(self, gain: float = 1.0, render_mode: str | None = None) -> None:
        self.gain = gain
        self.render_mode = render_mode
        self.observation_space = spaces.Box(-3.0, 3.0, (2,), np.float64)
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float64)
        self.position = np.zeros(2)

    def supervisor_action(self) -> np.ndarray:
        return np.clip(-self.gain * self.position, -1.0, 1.0)

    def _info(self) -> dict[str, Any]:
        return {SUPERVISOR_ACTION_KEY: self.supervisor_action()}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self.position = self.np_random.uniform(-2.0, 2.0, 2)
        return self.position.copy(), self._info()

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        command = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        drift = self.np_random.normal(0.0, DRIFT_STD, 2)
        self.position = np.clip(self.position + DT * command + drift, -3.0, 3.0)
        reward = float(np.exp(-self.position @ self.position))
        return self.position.copy(), reward, False, False, self._info()


if ENV_ID not in gym.registry:
    gym.register(ENV_ID, entry_point=PointMassEnv, max_episode_steps=20)
