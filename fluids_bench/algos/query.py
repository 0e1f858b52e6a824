"""Query selection for on-policy learning (ch. 6): which visited states to ask the supervisor about.

Every selector is fit on the current training set and the current learner, then marks the
states of a new rollout as risky (ask) or safe (do not ask):

- :class:`ShivSelector`, SHIV's risk (Eq. 7–8): a One-Class SVM ``g_s`` (``nu``, ``sigma``) on
  the states the learner predicts well and one ``g_r`` (``nu_r``, ``sigma_r``) on those it
  mispredicts; a state is safe only if it lies strictly inside the well-predicted level set
  and outside the mispredicted one. "Well predicted" means a loss ``<= epsilon``: 0/1 loss with
  ``epsilon = 0`` for Discrete actions, squared L2 loss for Box actions, where ``epsilon=None``
  takes the median training loss (the source's choice for grasping);
- :class:`NoveltySelector`: the plain One-Class SVM on all training states (no holes carved);
- :class:`ConfidenceSelector`: distance to a linear SVM's hyperplane (Tong & Koller); risky
  below the mean margin of the misclassified training states;
- :class:`CommitteeSelector`: query-by-committee of 3 linear SVMs bagged on overlapping 80%
  subsets; risky when they disagree;
- :class:`MMDSelector`: the Maximum Mean Discrepancy between a state and the training set
  (Kim & Pineau's MMD-IL); risky among the largest values, with the threshold at the
  ``1 - nu`` quantile of the training states' own values (the lowest 10% of similarity for
  ``nu = 0.1``).

The confidence and committee baselines need class labels: they accept Discrete actions only.
The Gaussian kernel is ``k(x, x') = exp(-|x - x'|^2 / (2 sigma^2))`` on raw observations, i.e.
scikit-learn's ``gamma = 1 / (2 sigma^2)``.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from gymnasium import spaces
from sklearn.metrics.pairwise import rbf_kernel
from sklearn.svm import OneClassSVM

from fluids_bench.algos.policies import Policy, PolicySpec, features, fit_policy

SELECTORS = ("shiv", "novelty", "confidence", "qbc", "mmd")


class QuerySelector(Protocol):
    def fit(self, observations: np.ndarray, labels: np.ndarray, policy: Policy) -> None:
        """Fit the risk model on the training pairs and the learner trained on them."""
        ...

    def risky(self, observations: np.ndarray) -> np.ndarray:
        """A boolean mask: True where the supervisor should be asked."""
        ...


def gamma_of(sigma: float) -> float:
    """scikit-learn's RBF ``gamma`` for bandwidth ``sigma``."""
    return 1.0 / (2.0 * sigma**2)


def surrogate_loss(predicted: np.ndarray, labels: np.ndarray, discrete: bool) -> np.ndarray:
    """Per-pair loss: 0/1 for Discrete actions, squared L2 for Box actions."""
    if discrete:
        return (np.asarray(predicted).reshape(-1) != np.asarray(labels).reshape(-1)).astype(float)
    diff = np.asarray(predicted, dtype=np.float64) - np.asarray(labels, dtype=np.float64)
    return np.sum(diff.reshape(len(diff), -1) ** 2, axis=1)


class _LevelSet:
    """A One-Class SVM level set; an empty training set gives an empty set."""

    def __init__(self, nu: float, sigma: float) -> None:
        self.nu, self.sigma = nu, sigma
        self.model: OneClassSVM | None = None

    def fit(self, X: np.ndarray) -> _LevelSet:
        self.model = None
        if len(X):
            self.model = OneClassSVM(nu=self.nu, gamma=gamma_of(self.sigma)).fit(X)
        return self

    def decision(self, X: np.ndarray) -> np.ndarray:
        """> 0 strictly inside, 0 on the boundary, < 0 outside (-inf everywhere if empty)."""
        if self.model is None:
            return np.full(len(X), -np.inf)
        return self.model.decision_function(X)


class ShivSelector:
    """SHIV's risk, Eq. 8: safe iff ``g_s(x) = 1`` (strictly inside) and ``g_r(x) = -1``."""

    def __init__(
        self,
        discrete: bool,
        nu: float = 0.1,
        sigma: float = 1.0,
        nu_r: float = 0.1,
        sigma_r: float = 1.0,
        epsilon: float | None = None,
    ) -> None:
        self.discrete = discrete
        self.epsilon = epsilon
        self.safe_set = _LevelSet(nu, sigma)
        self.mispredicted_set = _LevelSet(nu_r, sigma_r)

    def fit(self, observations: np.ndarray, labels: np.ndarray, policy: Policy) -> None:
        X = features(observations)
        loss = surrogate_loss(policy.predict(observations), labels, self.discrete)
        if self.discrete:
            threshold = 0.0
        elif self.epsilon is None:
            threshold = float(np.median(loss))
        else:
            threshold = self.epsilon
        well_predicted = loss <= threshold  # Eq. 7: y_i = 1
        self.safe_set.fit(X[well_predicted])
        self.mispredicted_set.fit(X[~well_predicted])

    def risky(self, observations: np.ndarray) -> np.ndarray:
        X = features(observations)
        inside_safe = self.safe_set.decision(X) > 0.0
        # the boundary of a mispredicted level set belongs to the hole: with few mispredicted
        # states the One-Class SVM puts them exactly on it
        in_hole = self.mispredicted_set.decision(X) >= 0.0
        return ~(inside_safe & ~in_hole)


class NoveltySelector:
    """Risky iff outside the One-Class SVM level set of all training states."""

    def __init__(self, nu: float = 0.1, sigma: float = 1.0) -> None:
        self.level_set = _LevelSet(nu, sigma)

    def fit(self, observations: np.ndarray, labels: np.ndarray, policy: Policy) -> None:
        self.level_set.fit(features(observations))

    def risky(self, observations: np.ndarray) -> np.ndarray:
        return ~(self.level_set.decision(features(observations)) > 0.0)


def _linear_svm(
    action_space: spaces.Space[Any], X: np.ndarray, y: np.ndarray, random_state: int
) -> Policy:
    return fit_policy(PolicySpec("linear_svm"), action_space, X, y, random_state)


def _margins(policy: Any, X: np.ndarray) -> np.ndarray:
    """Distance-like confidence: |f(x)| (binary) or top-1 minus top-2 score (one-vs-rest)."""
    scores = policy.estimator.decision_function(X)
    if scores.ndim == 1:
        return np.abs(scores)
    top_two = np.sort(scores, axis=1)[:, -2:]
    return top_two[:, 1] - top_two[:, 0]


class ConfidenceSelector:
    """Risky iff the margin of a linear SVM is below that of the average misclassified state."""

    def __init__(self, action_space: spaces.Space[Any], rng: np.random.Generator) -> None:
        _require_discrete(action_space, "confidence")
        self.action_space, self.rng = action_space, rng
        self.svm: Any = None
        self.threshold = 0.0

    def fit(self, observations: np.ndarray, labels: np.ndarray, policy: Policy) -> None:
        X = features(observations)
        self.svm = _linear_svm(self.action_space, X, labels, int(self.rng.integers(2**31 - 1)))
        if self.svm.estimator is None:  # one class: no hyperplane, nothing is uncertain
            self.threshold = 0.0
            return
        wrong = self.svm.predict(X) != np.asarray(labels).reshape(-1)
        self.threshold = float(np.mean(_margins(self.svm, X[wrong]))) if wrong.any() else 0.0

    def risky(self, observations: np.ndarray) -> np.ndarray:
        X = features(observations)
        if self.svm is None or self.svm.estimator is None:
            return np.zeros(len(X), dtype=bool)
        return _margins(self.svm, X) < self.threshold


class CommitteeSelector:
    """Query-by-committee: linear SVMs on random overlapping subsets; risky iff they disagree."""

    def __init__(
        self,
        action_space: spaces.Space[Any],
        rng: np.random.Generator,
        members: int = 3,
        fraction: float = 0.8,
    ) -> None:
        _require_discrete(action_space, "qbc")
        self.action_space, self.rng = action_space, rng
        self.members, self.fraction = members, fraction
        self.committee: list[Policy] = []

    def fit(self, observations: np.ndarray, labels: np.ndarray, policy: Policy) -> None:
        X, y = features(observations), np.asarray(labels).reshape(-1)
        size = max(1, int(round(self.fraction * len(X))))
        self.committee = []
        for _ in range(self.members):
            subset = self.rng.choice(len(X), size=size, replace=False)
            seed = int(self.rng.integers(2**31 - 1))
            self.committee.append(_linear_svm(self.action_space, X[subset], y[subset], seed))

    def risky(self, observations: np.ndarray) -> np.ndarray:
        votes = np.stack([member.predict(observations) for member in self.committee])
        return np.any(votes != votes[0], axis=0)


class MMDSelector:
    """MMD of a single state against the training set, thresholded at a training quantile.

    ``MMD^2(x, D) = k(x, x) - 2/n sum_i k(x, x_i) + 1/n^2 sum_ij k(x_i, x_j)``: with a Gaussian
    kernel only the middle term depends on ``x``, so ranking by MMD is ranking by (minus) the
    kernel density estimate.
    """

    def __init__(self, nu: float = 0.1, sigma: float = 1.0) -> None:
        self.nu, self.sigma = nu, sigma
        self.X = np.empty((0, 0))
        self.offset = 0.0  # 1/n^2 sum_ij k(x_i, x_j)
        self.threshold = np.inf

    def _density(self, X: np.ndarray) -> np.ndarray:
        """``1/n sum_i k(x, x_i)`` per row of ``X``, in chunks to bound memory."""
        chunks = [
            rbf_kernel(X[i : i + 1024], self.X, gamma=gamma_of(self.sigma)).mean(axis=1)
            for i in range(0, len(X), 1024)
        ]
        return np.concatenate(chunks) if chunks else np.empty(0)

    def mmd2(self, observations: np.ndarray) -> np.ndarray:
        return 1.0 - 2.0 * self._density(features(observations)) + self.offset

    def fit(self, observations: np.ndarray, labels: np.ndarray, policy: Policy) -> None:
        self.X = features(observations)
        self.offset = float(np.mean(self._density(self.X)))
        self.threshold = float(np.quantile(self.mmd2(observations), 1.0 - self.nu))

    def risky(self, observations: np.ndarray) -> np.ndarray:
        return self.mmd2(observations) > self.threshold


def _require_discrete(action_space: spaces.Space[Any], name: str) -> None:
    if not isinstance(action_space, spaces.Discrete):
        raise ValueError(
            f"query selector '{name}' needs class labels; allowed: Discrete action spaces "
            f"(got {action_space}); use 'shiv', 'novelty' or 'mmd' for Box actions"
        )
