"""Policies for the evaluate tests, importable as ``benchmark_policies:...`` specs."""

from __future__ import annotations

import numpy as np


class Counter:
    """Always action 0; counts its calls; raises KeyboardInterrupt at call ``stop_at``."""

    def __init__(self, stop_at: int | None = None) -> None:
        self.calls = 0
        self.stop_at = stop_at

    def act(self, obs: np.ndarray) -> int:
        self.calls += 1
        if self.stop_at is not None and self.calls >= self.stop_at:
            raise KeyboardInterrupt
        return 0


class BatchOnly:
    """A policy with predict(batch) only."""

    def predict(self, observations: np.ndarray) -> np.ndarray:
        return np.zeros(len(observations), dtype=np.int64)


def make() -> Counter:
    return Counter()


def make_for(task) -> BatchOnly:
    assert task.name == "gridworld"
    return BatchOnly()


class FluidsPredict:
    """A FLUIDS-v4 policy with predict(batch) only: a fixed map of the observation into the
    action box (episodes of different lengths, actions that vary with the state)."""

    def predict(self, observations: np.ndarray) -> np.ndarray:
        observations = np.asarray(observations, dtype=np.float64)
        return np.clip(np.sin(observations[:, :10] * 3.0), -1.0, 1.0).astype(np.float32)


class FluidsAct:
    """The same map with act(obs): a policy that may keep state, run one episode at a time."""

    def act(self, observation: np.ndarray) -> np.ndarray:
        return FluidsPredict().predict(np.asarray(observation)[None])[0]


def fluids_predict() -> FluidsPredict:
    return FluidsPredict()
