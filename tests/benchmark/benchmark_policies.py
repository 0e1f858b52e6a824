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
