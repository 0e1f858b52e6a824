"""A test double of the learner protocol: 1-nearest-neighbour in plain numpy, recording calls.

It has only `fit` and `predict` (no `set_spaces`, no `partial_fit`): what the protocol promises
the algorithms work with. It copies its training labels exactly, so it is a learner whose
errors are easy to reason about; `fits` and `predicts` record the batch sizes it was given.
"""

from __future__ import annotations

import numpy as np


class NearestLabel:
    def __init__(self) -> None:
        self.fits: list[int] = []
        self.predicts: list[int] = []
        self.observation_shapes: set[tuple[int, ...]] = set()
        self.label_dtypes: set[str] = set()
        self.X = np.empty((0, 0))
        self.y = np.empty(0)

    def fit(self, observations: np.ndarray, labels: np.ndarray) -> NearestLabel:
        observations, labels = np.asarray(observations), np.asarray(labels)
        self.fits.append(len(observations))
        self.observation_shapes.add(observations.shape[1:])
        self.label_dtypes.add(labels.dtype.kind)
        self.X = observations.reshape(len(observations), -1).astype(np.float64)
        self.y = labels
        return self

    def predict(self, observations: np.ndarray) -> np.ndarray:
        X = np.asarray(observations, dtype=np.float64).reshape(len(observations), -1)
        self.predicts.append(len(X))
        distances = ((X[:, None, :] - self.X[None, :, :]) ** 2).sum(axis=2)
        return self.y[np.argmin(distances, axis=1)]


def make() -> NearestLabel:
    """A factory, as `fluids-bench train --policy learner_double:make` names it."""
    return NearestLabel()


NOT_A_FACTORY = 3
