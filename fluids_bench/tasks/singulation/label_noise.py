"""A model of retroactive labelling by people (source ch. 5, Fig. 5.4).

The source's participants teleoperated five demonstrations, then labelled the same states
retroactively; the Pearson correlation between their retroactive and teleoperated controls was
0.60 in rotation and 0.22 in translation. The model: a retroactive label is the teleoperated
(supervisor's) label shrunk towards its mean plus independent Gaussian noise of the matching
variance, per action dimension `j`,

    y'_j = mu_j + rho_j (y_j - mu_j) + sqrt(1 - rho_j^2) sigma_j eps_j,   eps_j ~ N(0, 1),

then clipped to the action bounds (the labelling interface is bounded), where `mu_j` and
`sigma_j` are the mean and standard deviation of the teleoperated labels. Without clipping
`corr(y', y) = rho_j` exactly in expectation; `calibrate` picks the model's `rho_j` so
that the correlation measured after clipping, on the reference labels, is the target.
Teleoperated demonstrations keep their labels (a demonstration's labels are what was executed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# the source's measured retroactive-vs-teleoperated correlations: (rotation, translation)
SOURCE_CORRELATIONS = (0.60, 0.22)


@dataclass(frozen=True)
class RetroactiveLabelModel:
    """Per-dimension shrinkage `rho`, label mean `mu` and spread `sigma`, bounds [lo, hi]."""

    rho: np.ndarray
    mu: np.ndarray
    sigma: np.ndarray
    low: float = -1.0
    high: float = 1.0

    def corrupt(self, labels: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Retroactive versions of `labels` (n, d); draws n × d normals from `rng`."""
        y = np.asarray(labels, dtype=np.float64)
        eps = rng.standard_normal(y.shape)
        return self._apply(y, eps).astype(np.asarray(labels).dtype)

    def _apply(self, y: np.ndarray, eps: np.ndarray, rho: np.ndarray | None = None) -> np.ndarray:
        r = self.rho if rho is None else rho
        noisy = self.mu + r * (y - self.mu) + np.sqrt(1.0 - r**2) * self.sigma * eps
        return np.clip(noisy, self.low, self.high)


def pearson(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per-column Pearson correlation of two (n, d) arrays (0 where a column is constant)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    da, db = a - a.mean(axis=0), b - b.mean(axis=0)
    denominator = np.sqrt((da**2).sum(axis=0) * (db**2).sum(axis=0))
    return np.where(
        denominator > 0, (da * db).sum(axis=0) / np.where(denominator > 0, denominator, 1), 0.0
    )


def calibrate(
    reference: np.ndarray,
    targets: tuple[float, ...] = SOURCE_CORRELATIONS,
    seed: int = 0,
    low: float = -1.0,
    high: float = 1.0,
) -> RetroactiveLabelModel:
    """The model whose clipped retroactive labels of `reference` (teleoperated labels, (n, d))
    correlate with them at `targets` (bisection per dimension on common random numbers)."""
    y = np.asarray(reference, dtype=np.float64)
    targets_arr = np.asarray(targets, dtype=np.float64)
    if y.ndim != 2 or y.shape[1] != len(targets_arr):
        raise ValueError(
            f"calibrate: reference has shape {y.shape}; allowed: (n, {len(targets_arr)})"
        )
    if not np.all((targets_arr >= 0) & (targets_arr <= 1)):
        raise ValueError(f"calibrate: targets {targets}; allowed: correlations in [0, 1]")
    mu, sigma = y.mean(axis=0), y.std(axis=0)
    model = RetroactiveLabelModel(targets_arr.copy(), mu, sigma, low, high)
    # a large fixed resample of the reference, so the calibration is smooth in rho
    rng = np.random.default_rng(seed)
    rows = y[rng.integers(len(y), size=max(20_000, len(y)))]
    eps = rng.standard_normal(rows.shape)
    lo_r, hi_r = np.zeros_like(targets_arr), np.ones_like(targets_arr)
    for _ in range(40):
        mid = 0.5 * (lo_r + hi_r)
        measured = pearson(model._apply(rows, eps, mid), rows)
        below = measured < targets_arr
        lo_r = np.where(below, mid, lo_r)
        hi_r = np.where(below, hi_r, mid)
    return RetroactiveLabelModel(0.5 * (lo_r + hi_r), mu, sigma, low, high)
