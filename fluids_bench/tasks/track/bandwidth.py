"""The source's SHIV bandwidths on this suite's HOG features (ch. 6: sigma = sigma_r = 200).

A Gaussian kernel's bandwidth is a distance, so it only means something against the distances
between states. The source gives its sigma values (1 to 350, with 200 chosen by a grid search)
but neither its HOG parameters nor the scale of its HOG distances, and on this suite's
descriptor (L2-Hys normalised blocks, the car covering a few of 576 blocks) two states of a
track are at most ~3 apart: at sigma = 50 the kernel between any two states exceeds 0.998, so
the source's numbers used as they stand all mean "everything is similar".

The mapping used here anchors the source's grid-searched value to the usual well-tuned
bandwidth, the median heuristic: `sigma = sigma_source / 200 * m`, where `m` is the median
Euclidean distance between the distinct states of a supervisor demonstration on the track (raw
HOG, as the source's bandwidths are in raw feature units). Ratios between the source's values
are kept: sigma_source = 1 becomes m / 200 (every state not seen before is novel: "ask for
everything"), 350 becomes 1.75 m.
"""

from __future__ import annotations

import numpy as np
from sklearn.metrics.pairwise import euclidean_distances

SOURCE_ANCHOR = 200.0  # the source's grid-searched sigma (and sigma_r) for HOG features
MAX_STATES = 500  # distinct states used for the median (evenly spaced), bounding the cost


def median_state_distance(states: np.ndarray) -> float:
    """Median Euclidean distance between the distinct rows of `states` (> 0).

    Raises ValueError when fewer than two distinct states are given (no scale to measure)."""
    X = np.asarray(states, dtype=np.float64).reshape(len(states), -1)
    first: dict[bytes, int] = {}  # hashing rows: np.unique(axis=0) sorts them, slow at HOG width
    for i, row in enumerate(X):
        first.setdefault(row.tobytes(), i)
    distinct = X[sorted(first.values())]
    if len(distinct) < 2:
        raise ValueError(
            f"median_state_distance: 'states' has {len(distinct)} distinct row(s); "
            "allowed: at least 2 distinct states"
        )
    if len(distinct) > MAX_STATES:
        distinct = distinct[np.linspace(0, len(distinct) - 1, MAX_STATES).round().astype(int)]
    distances = euclidean_distances(distinct)
    return float(np.median(distances[np.triu_indices(len(distinct), k=1)]))


def source_sigma(sigma_source: float, scale: float) -> float:
    """The bandwidth here for the source's `sigma_source`, given the track's state scale
    `scale` (`median_state_distance`)."""
    if not (np.isfinite(sigma_source) and sigma_source > 0):
        raise ValueError(f"source_sigma: 'sigma_source' is {sigma_source!r}; allowed: > 0")
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"source_sigma: 'scale' is {scale!r}; allowed: > 0")
    return float(sigma_source) / SOURCE_ANCHOR * float(scale)
