"""Query selection for on-policy learning (ch. 6): which visited states to ask the supervisor about.

Every selector is fit on the current training set and the current learner, then marks the
states of a new rollout as risky (ask) or safe (do not ask):

- `ShivSelector`, SHIV's risk (Eq. 7–8): a One-Class SVM `g_s` (`nu`, `sigma`) on
  the states the learner predicts well and one `g_r` (`nu_r`, `sigma_r`) on those it
  mispredicts; a state is safe only if it lies strictly inside the well-predicted level set
  and outside the mispredicted one. "Well predicted" means a loss `<= epsilon`: 0/1 loss with
  `epsilon = 0` for Discrete actions, the L2 distance between predicted and supervisor
  action for Box actions, where `epsilon=None` takes the median training error (the
  source's choice for grasping). When the learner predicts every training state within
  `epsilon` (a deep tree on consistent Discrete labels) there is no mispredicted set and SHIV
  *is* novelty detection (`NoveltySelector` on the same states);
- `NoveltySelector`: the plain One-Class SVM on all training states (no holes carved);
- `ConfidenceSelector`: distance to a linear SVM's hyperplane (Tong & Koller); risky
  below the mean margin of the misclassified training states;
- `CommitteeSelector`: query-by-committee of 3 linear SVMs bagged on overlapping 80%
  subsets; risky when they disagree;
- `MMDSelector`: the Maximum Mean Discrepancy between a state and the training set
  (Kim & Pineau's MMD-IL); risky among the largest values, with the threshold at the
  `1 - nu` quantile of the training states' own values (the lowest 10% of similarity for
  `nu = 0.1`).

The confidence and committee baselines need class labels: they accept Discrete actions only.
Their linear SVM is `svm` (a `PolicySpec`; default
`linear_svm` with scikit-learn's C = 1).
The Gaussian kernel is `k(x, x') = exp(-|x - x'|^2 / (2 sigma^2))`, i.e. scikit-learn's
`gamma = 1 / (2 sigma^2)`. Bandwidths (`KernelSpace`): an explicit `sigma` is in the
units of the raw observation, as the source states its values (200 on HOG features, 5 and 6 on
the grasping state); `sigma=None` standardises every feature on the first training set a
selector is fit on (in SHIV, the initial demonstrations, where the source tunes its bandwidths)
and takes the median distance between its distinct states (the "median heuristic"), then keeps
both for the rest of the run. So the default means the same on a gridworld's cells and on
FLUIDS' metres and radians, and does not drift when the learner's rollouts pile up near-identical
states (a car standing still).
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from gymnasium import spaces
from sklearn.metrics.pairwise import euclidean_distances, rbf_kernel
from sklearn.svm import OneClassSVM

from fluids_bench.algos.policies import Policy, PolicySpec, features, fit_policy

SELECTORS = ("shiv", "novelty", "confidence", "qbc", "mmd")
# distinct training states used for the median heuristic (the median of ~125k distances)
MEDIAN_HEURISTIC_STATES = 500


class QuerySelector(Protocol):
    def fit(self, observations: np.ndarray, labels: np.ndarray, policy: Policy) -> None:
        """Fit the risk model on the training pairs and the learner trained on them."""
        ...

    def risky(self, observations: np.ndarray) -> np.ndarray:
        """A boolean mask: True where the supervisor should be asked."""
        ...


def gamma_of(sigma: float) -> float:
    """scikit-learn's RBF `gamma` for bandwidth `sigma`."""
    return 1.0 / (2.0 * sigma**2)


def surrogate_loss(predicted: np.ndarray, labels: np.ndarray, discrete: bool) -> np.ndarray:
    """Per-pair error: 0/1 for Discrete actions, the L2 distance for Box actions."""
    if discrete:
        return (np.asarray(predicted).reshape(-1) != np.asarray(labels).reshape(-1)).astype(float)
    diff = np.asarray(predicted, dtype=np.float64) - np.asarray(labels, dtype=np.float64)
    return np.sqrt(np.sum(diff.reshape(len(diff), -1) ** 2, axis=1))


def median_distance(X: np.ndarray) -> float:
    """Median Euclidean distance between distinct rows of `X` (1.0 if there are none).

    At most `MEDIAN_HEURISTIC_STATES` rows, evenly spaced, so the cost stays bounded.
    """
    distinct = np.unique(X, axis=0)
    if len(distinct) < 2:
        return 1.0
    if len(distinct) > MEDIAN_HEURISTIC_STATES:
        keep = np.linspace(0, len(distinct) - 1, MEDIAN_HEURISTIC_STATES).round().astype(int)
        distinct = distinct[keep]
    distances = euclidean_distances(distinct)
    return float(np.median(distances[np.triu_indices(len(distinct), k=1)]))


class KernelSpace:
    """The feature space and bandwidth a kernel selector works in.

    `sigma` given: raw observations, that bandwidth. `sigma=None`: features standardised on
    the first training set (constant features keep scale 1), bandwidth by the median
    heuristic on it; later fits keep both.
    """

    def __init__(self, sigma: float | None) -> None:
        self.requested = sigma
        self.sigma = 1.0 if sigma is None else float(sigma)
        self.mean: np.ndarray | float = 0.0
        self.scale: np.ndarray | float = 1.0
        self.fitted = False

    def fit(self, X: np.ndarray) -> KernelSpace:
        if self.requested is None and not self.fitted:
            self.fitted = True
            self.mean = X.mean(axis=0)
            std = X.std(axis=0)
            self.scale = np.where(std > 0.0, std, 1.0)
            self.sigma = median_distance(self.transform(X))
        return self

    def transform(self, X: np.ndarray) -> np.ndarray:
        return (X - self.mean) / self.scale


def _gaussian_kernel(A: np.ndarray, B: np.ndarray, sigma: float) -> np.ndarray:
    """`k(a, b)` for all rows, by matrix products, and exactly 1 between identical rows.

    libsvm's own RBF gives identical rows distance 0 exactly; the matrix-product distance can
    leave ~1e-15 there, which would move a repeated training state off a level set's boundary
    (where SHIV's holes put their own states)."""
    squared = euclidean_distances(A, B, squared=True)
    rows: dict[bytes, list[int]] = {}
    for j, row in enumerate(B):
        rows.setdefault(row.tobytes(), []).append(j)
    for i, row in enumerate(A):
        same = rows.get(row.tobytes())
        if same:
            squared[i, same] = 0.0
    return np.exp(-gamma_of(sigma) * squared)


class _LevelSet:
    """A One-Class SVM level set; an empty training set gives an empty set."""

    def __init__(self, nu: float, sigma: float) -> None:
        self.nu, self.sigma = nu, sigma
        self.model: OneClassSVM | None = None
        self.X = np.empty((0, 0))

    def fit(self, X: np.ndarray, sigma: float | None = None) -> _LevelSet:
        self.model = None
        if sigma is not None:
            self.sigma = sigma
        if len(X):
            # the Gaussian kernel computed once, by matrix products: libsvm's own RBF evaluates it
            # entry by entry, which on wide features (20,736 HOG dimensions) costs ~10x more
            self.X = X
            gram = _gaussian_kernel(X, X, self.sigma)
            self.model = OneClassSVM(nu=self.nu, kernel="precomputed").fit(gram)
        return self

    def decision(self, X: np.ndarray) -> np.ndarray:
        """> 0 strictly inside, 0 on the boundary, < 0 outside (-inf everywhere if empty)."""
        if self.model is None:
            return np.full(len(X), -np.inf)
        # libsvm reads only the support vectors' columns of a precomputed kernel
        support = self.model.support_
        kernel = np.zeros((len(X), len(self.X)))
        kernel[:, support] = _gaussian_kernel(X, self.X[support], self.sigma)
        return self.model.decision_function(kernel)


def check_bandwidths(where: str, sigma: float | None, sigma_r: float | None) -> None:
    """`sigma_r` alone has no units to live in: an explicit bandwidth is in raw units."""
    if sigma is None and sigma_r is not None:
        raise ValueError(
            f"{where}: field 'sigma_r' is {sigma_r!r} while 'sigma' is None; allowed: None, or "
            "give 'sigma' too (explicit bandwidths are in raw observation units, sigma=None "
            "standardises the features and picks both bandwidths by the median heuristic)"
        )


class ShivSelector:
    """SHIV's risk, Eq. 8: safe iff `g_s(x) = 1` (strictly inside) and `g_r(x) = -1`.

    Defaults are the source's (ch. 6): `nu = 0.1`, `nu_r = 1e-3`, `epsilon` = the median
    training error for Box actions; `sigma=None` is the scale-aware bandwidth of
    `KernelSpace` and `sigma_r=None` equals `sigma`.
    """

    def __init__(
        self,
        discrete: bool,
        nu: float = 0.1,
        sigma: float | None = None,
        nu_r: float = 1e-3,
        sigma_r: float | None = None,
        epsilon: float | None = None,
    ) -> None:
        check_bandwidths("ShivSelector", sigma, sigma_r)
        self.discrete = discrete
        self.epsilon = epsilon
        self.space = KernelSpace(sigma)
        self.requested_sigma_r = sigma_r
        self.safe_set = _LevelSet(nu, self.space.sigma)
        self.mispredicted_set = _LevelSet(nu_r, self.space.sigma if sigma_r is None else sigma_r)
        self.mispredicted = 0  # training states outside epsilon at the last fit: |D_r|

    @property
    def sigma(self) -> float:
        return self.safe_set.sigma

    @property
    def sigma_r(self) -> float:
        return self.mispredicted_set.sigma

    def fit(self, observations: np.ndarray, labels: np.ndarray, policy: Policy) -> None:
        X = self.space.fit(features(observations)).transform(features(observations))
        loss = surrogate_loss(policy.predict(observations), labels, self.discrete)
        if self.discrete:
            threshold = 0.0
        elif self.epsilon is None:
            threshold = float(np.median(loss))
        else:
            threshold = self.epsilon
        well_predicted = loss <= threshold  # Eq. 7: y_i = 1
        self.mispredicted = int(np.count_nonzero(~well_predicted))
        sigma_r = self.space.sigma if self.requested_sigma_r is None else self.requested_sigma_r
        self.safe_set.fit(X[well_predicted], self.space.sigma)
        self.mispredicted_set.fit(X[~well_predicted], sigma_r)

    def risky(self, observations: np.ndarray) -> np.ndarray:
        X = self.space.transform(features(observations))
        inside_safe = self.safe_set.decision(X) > 0.0
        # the boundary of a mispredicted level set belongs to the hole: with few mispredicted
        # states the One-Class SVM puts them exactly on it
        in_hole = self.mispredicted_set.decision(X) >= 0.0
        return ~(inside_safe & ~in_hole)


class NoveltySelector:
    """Risky iff outside the One-Class SVM level set of all training states."""

    def __init__(self, nu: float = 0.1, sigma: float | None = None) -> None:
        self.space = KernelSpace(sigma)
        self.level_set = _LevelSet(nu, self.space.sigma)

    def fit(self, observations: np.ndarray, labels: np.ndarray, policy: Policy) -> None:
        X = self.space.fit(features(observations)).transform(features(observations))
        self.level_set.fit(X, self.space.sigma)

    def risky(self, observations: np.ndarray) -> np.ndarray:
        X = self.space.transform(features(observations))
        return ~(self.level_set.decision(X) > 0.0)


LINEAR_SVM = PolicySpec("linear_svm")  # the baselines' classifier unless one is given


def _margins(policy: Any, X: np.ndarray) -> np.ndarray:
    """Distance-like confidence: |f(x)| (binary) or top-1 minus top-2 score (one-vs-rest)."""
    scores = policy.estimator.decision_function(X)
    if scores.ndim == 1:
        return np.abs(scores)
    top_two = np.sort(scores, axis=1)[:, -2:]
    return top_two[:, 1] - top_two[:, 0]


class ConfidenceSelector:
    """Risky iff the margin of a linear SVM is below that of the average misclassified state."""

    def __init__(
        self,
        action_space: spaces.Space[Any],
        rng: np.random.Generator,
        svm: PolicySpec = LINEAR_SVM,
    ) -> None:
        _require_discrete(action_space, "confidence")
        self.action_space, self.rng, self.spec = action_space, rng, svm
        self.svm: Any = None
        self.threshold = 0.0

    def fit(self, observations: np.ndarray, labels: np.ndarray, policy: Policy) -> None:
        X = features(observations)
        seed = int(self.rng.integers(2**31 - 1))
        self.svm = fit_policy(self.spec, self.action_space, X, labels, seed)
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
        svm: PolicySpec = LINEAR_SVM,
    ) -> None:
        _require_discrete(action_space, "qbc")
        self.action_space, self.rng, self.spec = action_space, rng, svm
        self.members, self.fraction = members, fraction
        self.committee: list[Policy] = []

    def fit(self, observations: np.ndarray, labels: np.ndarray, policy: Policy) -> None:
        X, y = features(observations), np.asarray(labels).reshape(-1)
        size = max(1, int(round(self.fraction * len(X))))
        self.committee = []
        for _ in range(self.members):
            subset = self.rng.choice(len(X), size=size, replace=False)
            seed = int(self.rng.integers(2**31 - 1))
            self.committee.append(
                fit_policy(self.spec, self.action_space, X[subset], y[subset], seed)
            )

    def risky(self, observations: np.ndarray) -> np.ndarray:
        votes = np.stack([member.predict(observations) for member in self.committee])
        return np.any(votes != votes[0], axis=0)


class MMDSelector:
    """MMD of a single state against the training set, thresholded at a training quantile.

    `MMD^2(x, D) = k(x, x) - 2/n sum_i k(x, x_i) + 1/n^2 sum_ij k(x_i, x_j)`: with a Gaussian
    kernel only the middle term depends on `x`, so ranking by MMD is ranking by (minus) the
    kernel density estimate.
    """

    def __init__(self, nu: float = 0.1, sigma: float | None = None) -> None:
        self.nu = nu
        self.space = KernelSpace(sigma)
        self.X = np.empty((0, 0))
        self.offset = 0.0  # 1/n^2 sum_ij k(x_i, x_j)
        self.threshold = np.inf

    def _density(self, X: np.ndarray) -> np.ndarray:
        """`1/n sum_i k(x, x_i)` per row of `X`, in chunks to bound memory."""
        chunks = [
            rbf_kernel(X[i : i + 1024], self.X, gamma=gamma_of(self.space.sigma)).mean(axis=1)
            for i in range(0, len(X), 1024)
        ]
        return np.concatenate(chunks) if chunks else np.empty(0)

    def mmd2(self, observations: np.ndarray) -> np.ndarray:
        X = self.space.transform(features(observations))
        return 1.0 - 2.0 * self._density(X) + self.offset

    def fit(self, observations: np.ndarray, labels: np.ndarray, policy: Policy) -> None:
        self.X = self.space.fit(features(observations)).transform(features(observations))
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
