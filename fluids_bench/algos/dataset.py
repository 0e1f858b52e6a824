"""Trajectories, aggregated datasets of state–label pairs, and the ch. 3 subsampling protocol.

A trajectory `xi = (x_0, u_0, x_1, ..., x_T)` (ch. 1) has one more observation than actions.
Next to the executed actions `u_t` it stores the supervisor's labels `u*_t` for the states
`x_t` the actions were taken from (`info["supervisor_action"]`), whoever acted. Algorithms
decide which labels they actually use; only those count as requested.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class Trajectory:
    """One episode: `observations` has `T + 1` rows, the other per-step arrays `T`."""

    observations: np.ndarray
    actions: np.ndarray
    labels: np.ndarray
    rewards: np.ndarray
    infos: list[dict[str, Any]]  # T + 1 entries: the reset info first
    terminated: bool
    truncated: bool
    seed: int

    def __post_init__(self) -> None:
        steps = len(self.actions)
        if len(self.observations) != steps + 1:
            raise ValueError(
                f"Trajectory: {len(self.observations)} observations for {steps} actions; "
                "allowed: exactly one more observation than actions"
            )
        if not len(self.labels) == len(self.rewards) == steps or len(self.infos) != steps + 1:
            raise ValueError("Trajectory: labels and rewards need T rows, infos T + 1")

    def __len__(self) -> int:
        return len(self.actions)

    @property
    def total_return(self) -> float:
        return float(np.sum(self.rewards))

    @property
    def states(self) -> np.ndarray:
        """The `T` observations actions were taken from (the last one has no label)."""
        return self.observations[:-1]


@dataclass
class Dataset:
    """An aggregate of state–label pairs `D = D_1 ∪ D_2 ∪ ...` (rows are appended in order)."""

    _observations: list[np.ndarray] = field(default_factory=list)
    _labels: list[np.ndarray] = field(default_factory=list)
    _size: int = 0

    def __len__(self) -> int:
        return self._size

    def add(self, observations: np.ndarray, labels: np.ndarray) -> None:
        """Aggregate a batch of pairs (row `i` of `labels` labels row `i` of observations)."""
        if len(observations) != len(labels):
            raise ValueError(
                f"Dataset.add: {len(observations)} observations but {len(labels)} labels"
            )
        if len(observations):
            self._observations.append(np.asarray(observations))
            self._labels.append(np.asarray(labels))
            self._size += len(observations)

    def extend(self, other: Dataset) -> None:
        """Aggregate another dataset."""
        if len(other):
            self.add(*other.arrays())

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """All observations and labels so far, concatenated."""
        if not self._observations:
            raise ValueError("Dataset.arrays: the dataset is empty")
        observations = np.concatenate(self._observations)
        labels = np.concatenate(self._labels)
        # keep one chunk so repeated calls stay cheap
        self._observations, self._labels = [observations], [labels]
        return observations, labels


def split_pairs(
    n_pairs: int,
    samples_per_demo: int | None,
    heldout_fraction: float,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the training and held-out pairs of one demonstration (ch. 3 protocol).

    First `round(heldout_fraction * n_pairs)` pairs are drawn at random and held out (the
    state-level experiment holds out 10%); of the rest, `samples_per_demo` drawn at random are
    kept for training (Ho & Ermon's 50 per demonstration) and the others are held out too.
    `samples_per_demo=None` keeps every remaining pair for training. Indices come back sorted.
    """
    order = rng.permutation(n_pairs)
    n_heldout = int(round(heldout_fraction * n_pairs))
    candidates = order[n_heldout:]
    n_train = (
        len(candidates) if samples_per_demo is None else min(samples_per_demo, len(candidates))
    )
    train = np.sort(candidates[:n_train])
    heldout = np.sort(np.concatenate([order[:n_heldout], candidates[n_train:]]))
    return train, heldout
