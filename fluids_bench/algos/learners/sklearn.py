"""The scikit-learn learner families, for any Discrete or Box action space.

A `PolicySpec` names a model family and its parameters; `fit_policy` turns it into
a classifier (Discrete actions) or a regressor (Box actions), fits it on state–label pairs and
returns a `FittedPolicy`, which predicts actions in the env's action space.

Model families (`PolicySpec.name`):

- `linear_svm`: linear SVM (`LinearSVC` / `LinearSVR` per output dimension), on
  standardised features, as the source's low-expressiveness class (ch. 3, ch. 6);
- `linear_svm_span`: the same classifier problem as `linear_svm` solved in the span of the
  distinct training states (`SpanLinearSVC`), for features far wider than the data
  (ch. 6's 20,736-dimensional HOG); Box actions fall back to `linear_svm`'s regressor;
- `tree`: decision tree, `max_depth` as given (the source uses depth 100 as its
  high-expressiveness class);
- `kernel_ridge`: RBF kernel ridge regression (ch. 6's grasping policy); for Discrete actions
  it regresses one-hot labels and takes the arg-max;
- `knn`: k nearest neighbours (k is capped at the number of training pairs);
- `mlp`: a small multi-layer perceptron;
- `constant`: the constant policy class of ch. 4 (majority label, or mean label for Box),
  ties going to the lowest action index; computed directly, without an estimator.

A classifier fit on a single label predicts that label everywhere: most scikit-learn
classifiers refuse one-class data, and on-policy data often starts that way.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from gymnasium import spaces
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.exceptions import ConvergenceWarning
from sklearn.kernel_ridge import KernelRidge
from sklearn.multioutput import MultiOutputRegressor
from sklearn.neighbors import KNeighborsClassifier, KNeighborsRegressor
from sklearn.neural_network import MLPClassifier, MLPRegressor
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import LinearSVC, LinearSVR
from sklearn.tree import DecisionTreeClassifier, DecisionTreeRegressor

from fluids_bench.algos.learners.protocol import check_action_space, features
from fluids_bench.core.validation import check_bool, check_choice, fail

# Predictions of one fitted policy are memoised per observation, up to this many entries:
# gridworld-like envs revisit the same few hundred states thousands of times, and a single
# scikit-learn predict call costs ~0.3 ms.
PREDICTION_CACHE_SIZE = 100_000


class KernelRidgeClassifier(ClassifierMixin, BaseEstimator):
    """RBF kernel ridge regression on one-hot labels; predicts the arg-max class."""

    def __init__(self, alpha: float = 1.0, gamma: float | None = None) -> None:
        self.alpha = alpha
        self.gamma = gamma

    def fit(self, X: np.ndarray, y: np.ndarray) -> KernelRidgeClassifier:
        self.classes_, codes = np.unique(y, return_inverse=True)
        targets = np.eye(len(self.classes_))[codes]
        self.model_ = KernelRidge(alpha=self.alpha, kernel="rbf", gamma=self.gamma).fit(X, targets)
        return self

    def predict(self, X: np.ndarray) -> np.ndarray:
        return self.classes_[np.argmax(self.model_.predict(X), axis=1)]


def distinct_rows(X: np.ndarray) -> np.ndarray:
    """Index of the first occurrence of each distinct row of `X` (rows hashed as bytes)."""
    first: dict[bytes, int] = {}
    for i, row in enumerate(np.ascontiguousarray(X).reshape(len(X), -1)):
        first.setdefault(row.tobytes(), i)
    return np.fromiter(first.values(), dtype=np.int64, count=len(first))


def _distinct_pairs(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index of the first occurrence of each distinct (row, label) pair, and its count.

    By hashing rows: `np.unique(axis=0)` sorts wide rows and costs seconds at HOG width."""
    index: dict[tuple[bytes, Any], int] = {}
    first: list[int] = []
    counts: list[int] = []
    for i, (row, label) in enumerate(zip(X, y.tolist(), strict=True)):
        j = index.setdefault((row.tobytes(), label), len(first))
        if j == len(first):
            first.append(i)
            counts.append(0)
        counts[j] += 1
    return np.asarray(first, dtype=np.int64), np.asarray(counts, dtype=np.float64)


class SpanLinearSVC(ClassifierMixin, BaseEstimator):
    """`make_pipeline(StandardScaler(), LinearSVC(C, ...))`'s problem, solved in `n` not `d`
    dimensions: for `n` distinct training states of `d >> n` features.

    LinearSVC (liblinear's dual coordinate descent, squared hinge, one-vs-rest, the intercept
    regularised as a constant feature 1) only ever sees the training vectors through their inner
    products, and its weights lie in their span. So it is fit on `Z = V Λ^½` (`K = V Λ Vᵀ`,
    `K` the Gram matrix of the standardised vectors with the constant 1 appended), which has the
    same Gram matrix: the same dual problem and, in exact arithmetic, the same iterates. The
    weights are mapped back (`w = Xᵀ V Λ^-½ v`) and the standardisation folded into them.
    Repeated (state, label) pairs are fit once with their count as `sample_weight`, which is
    the same primal objective (and standardisation) as the repeated rows. A pass of the solver
    costs `O(n²)` instead of `O(n d)`.
    """

    def __init__(
        self, C: float = 1.0, tol: float = 1e-4, max_iter: int = 1000, random_state: Any = None
    ) -> None:
        self.C, self.tol, self.max_iter, self.random_state = C, tol, max_iter, random_state

    def fit(self, X: np.ndarray, y: np.ndarray) -> SpanLinearSVC:
        X = np.asarray(X, dtype=np.float64)
        y = np.asarray(y).reshape(-1)
        first, weight = _distinct_pairs(X, y)
        X, y = X[first], y[first]
        scaler = StandardScaler().fit(X, sample_weight=weight)
        augmented = np.column_stack([scaler.transform(X), np.ones(len(X))])
        lam, V = np.linalg.eigh(augmented @ augmented.T)
        keep = lam > lam[-1] * len(lam) * np.finfo(np.float64).eps  # drop the null space
        lam, V = lam[keep], V[:, keep]
        svc = LinearSVC(
            C=self.C, fit_intercept=False, dual=True, tol=self.tol, max_iter=self.max_iter,
            random_state=self.random_state,
        ).fit(V * np.sqrt(lam), y, sample_weight=weight)  # fmt: skip
        coef = (svc.coef_ / np.sqrt(lam)) @ V.T @ augmented  # rows: [w_standardised, b]
        self.coef_ = coef[:, :-1] / scaler.scale_
        self.intercept_ = coef[:, -1] - self.coef_ @ scaler.mean_
        self.classes_ = svc.classes_
        self.n_iter_ = svc.n_iter_
        return self

    def decision_function(self, X: np.ndarray) -> np.ndarray:
        scores = np.asarray(X, dtype=np.float64) @ self.coef_.T + self.intercept_
        return scores[:, 0] if scores.shape[1] == 1 else scores

    def predict(self, X: np.ndarray) -> np.ndarray:
        scores = self.decision_function(X)
        best = (scores > 0).astype(int) if scores.ndim == 1 else np.argmax(scores, axis=1)
        return self.classes_[best]


def _scaled(estimator: BaseEstimator, standardize: bool) -> BaseEstimator:
    """`estimator` on standardised features, or on the raw ones (`PolicySpec.standardize`)."""
    return make_pipeline(StandardScaler(), estimator) if standardize else estimator


# name -> (classifier factory, regressor factory); factories take (params, random_state,
# standardize)
Factory = Callable[[dict[str, Any], int, bool], BaseEstimator]
MODELS: dict[str, tuple[Factory, Factory]] = {
    "linear_svm": (
        lambda p, rs, sc: _scaled(LinearSVC(random_state=rs, **p), sc),
        lambda p, rs, sc: _scaled(MultiOutputRegressor(LinearSVR(random_state=rs, **p)), sc),
    ),
    "linear_svm_span": (
        lambda p, rs, sc: SpanLinearSVC(random_state=rs, **p),
        lambda p, rs, sc: _scaled(MultiOutputRegressor(LinearSVR(random_state=rs, **p)), sc),
    ),
    "tree": (
        lambda p, rs, sc: DecisionTreeClassifier(random_state=rs, **p),
        lambda p, rs, sc: DecisionTreeRegressor(random_state=rs, **p),
    ),
    "kernel_ridge": (
        lambda p, rs, sc: _scaled(KernelRidgeClassifier(**p), sc),
        lambda p, rs, sc: _scaled(KernelRidge(**{"kernel": "rbf", **p}), sc),
    ),
    "knn": (
        lambda p, rs, sc: _scaled(KNeighborsClassifier(**p), sc),
        lambda p, rs, sc: _scaled(KNeighborsRegressor(**p), sc),
    ),
    "mlp": (
        lambda p, rs, sc: _scaled(MLPClassifier(random_state=rs, **{"max_iter": 500, **p}), sc),
        lambda p, rs, sc: _scaled(MLPRegressor(random_state=rs, **{"max_iter": 500, **p}), sc),
    ),
}
# the constant class needs no estimator: fit_policy computes the majority / mean label itself
FAMILIES = (*sorted(MODELS), "constant")


@dataclass(frozen=True)
class PolicySpec:
    """A model family from `MODELS` and keyword parameters for its estimator."""

    name: str = "tree"
    params: Mapping[str, Any] = field(default_factory=dict)
    # False: the families that standardise their features (linear_svm, kernel_ridge, knn, mlp)
    # fit on the raw ones instead (where state units carry meaning, e.g. grasping's metres);
    # linear_svm_span's classifier always standardises (the problem it solves is linear_svm's)
    standardize: bool = True

    def __post_init__(self) -> None:
        check_choice("PolicySpec", "name", self.name, FAMILIES)
        check_bool("PolicySpec", "standardize", self.standardize)
        if not isinstance(self.params, Mapping):
            raise ValueError(
                f"PolicySpec: field 'params' is {self.params!r}; allowed: a mapping of keywords"
            )
        if self.name == "constant":
            if self.params:
                fail("PolicySpec", "params", dict(self.params), "{} for 'constant'")
            return
        # fail now, not after the first rollout, if the estimator rejects a parameter
        for factory in MODELS[self.name]:
            try:
                factory(dict(self.params), 0, self.standardize)
            except TypeError as exc:
                raise ValueError(
                    f"PolicySpec: params {dict(self.params)} for '{self.name}': {exc}"
                ) from exc


def _predict(estimator: BaseEstimator, X: np.ndarray) -> np.ndarray:
    """`estimator.predict(X)`; for fitted decision trees, straight through the tree.

    scikit-learn's `predict` spends almost all of a one-row call validating its input
    (~240 µs against ~7 µs for the tree itself), and policies are asked one row per env step.
    The tree path gives bit-identical output: it is what `predict` runs after validating.
    """
    if isinstance(estimator, DecisionTreeRegressor):
        out = estimator.tree_.predict(X.astype(np.float32))
        return out[:, 0] if estimator.n_outputs_ == 1 else out[:, :, 0]
    if isinstance(estimator, DecisionTreeClassifier) and estimator.n_outputs_ == 1:
        proba = estimator.tree_.predict(X.astype(np.float32))
        return estimator.classes_.take(np.argmax(proba, axis=1), axis=0)
    return estimator.predict(X)


class FittedPolicy:
    """A trained learner: maps observations to actions of `action_space`."""

    def __init__(
        self, estimator: BaseEstimator | None, action_space: spaces.Space[Any], constant: Any = None
    ) -> None:
        self.estimator = estimator  # None when every training label was the same
        self.action_space = action_space
        self.discrete = check_action_space(action_space)
        self.constant = constant
        self._cache: dict[bytes, Any] = {}

    def predict(self, observations: np.ndarray) -> np.ndarray:
        """Actions for a batch of observations (Discrete: int64 `(n,)`; Box: `(n, *shape)`)."""
        X = features(observations)
        if self.estimator is None:
            return np.repeat(np.asarray(self.constant)[None], len(X), axis=0)
        raw = np.asarray(_predict(self.estimator, X))
        if self.discrete:
            return raw.astype(np.int64).reshape(len(X))
        shape = self.action_space.shape
        return np.clip(raw.reshape((len(X), *shape)), self.action_space.low, self.action_space.high)

    def prime(self, observations: np.ndarray) -> None:
        """Fill the memo with one batch prediction (a batch costs about what one row costs)."""
        batch = np.asarray(observations)[: PREDICTION_CACHE_SIZE - len(self._cache)]
        if len(batch) == 0:
            return
        for row, action in zip(batch, self.predict(batch), strict=True):
            self._cache[row.tobytes()] = action

    def act(self, observation: np.ndarray) -> Any:
        """The action for one observation (memoised: the policy never changes after fitting)."""
        obs = np.asarray(observation)
        key = obs.tobytes()
        action = self._cache.get(key)
        if action is None:
            action = self.predict(obs[None])[0]
            if len(self._cache) < PREDICTION_CACHE_SIZE:
                self._cache[key] = action
        return action.copy() if isinstance(action, np.ndarray) else action


def fit_policy(
    spec: PolicySpec,
    action_space: spaces.Space[Any],
    observations: np.ndarray,
    labels: np.ndarray,
    random_state: int,
) -> FittedPolicy:
    """Fit the model family of `spec` on state–label pairs."""
    discrete = check_action_space(action_space)
    if len(observations) == 0:
        raise ValueError("fit_policy: no training pairs; collect at least one labelled state")
    X = features(observations)
    if discrete:
        y = np.asarray(labels).astype(np.int64).reshape(len(X))
        classes, counts = np.unique(y, return_counts=True)
        if len(classes) == 1 or spec.name == "constant":
            # the majority label; argmax takes the first (lowest) label on ties
            return FittedPolicy(None, action_space, np.int64(classes[np.argmax(counts)]))
    else:
        y = np.asarray(labels, dtype=np.float64).reshape(len(X), -1)
        if spec.name == "constant":
            mean = y.mean(axis=0).reshape(action_space.shape).astype(action_space.dtype)
            return FittedPolicy(None, action_space, mean)
    params = dict(spec.params)
    if spec.name == "knn":
        params["n_neighbors"] = min(int(params.get("n_neighbors", 5)), len(X))
    factory = MODELS[spec.name][0 if discrete else 1]  # not constant
    estimator = factory(params, random_state, spec.standardize)
    with warnings.catch_warnings():
        # small imitation datasets rarely let iterative solvers converge; the benchmark reports
        # what the given budget achieves instead of printing a warning per fit
        warnings.simplefilter("ignore", ConvergenceWarning)
        estimator.fit(X, y)
    policy = FittedPolicy(estimator, action_space)
    # the learner mostly revisits states like its training states: predict those in one call
    observations = np.asarray(observations)
    policy.prime(observations[distinct_rows(observations)])
    return policy


class SklearnLearner:
    """A scikit-learn family (a `PolicySpec`) as a [`Learner`][fluids_bench.algos.learners.Learner].

    Each `fit` fits afresh with `random_state`. Without `set_spaces` the action space is
    inferred from the labels: integer labels are Discrete classes `0..max`, others a Box.
    """

    def __init__(
        self, spec: PolicySpec | str = "tree", random_state: int = 0, **params: Any
    ) -> None:
        if isinstance(spec, str):
            spec = PolicySpec(spec, params)
        elif params:
            raise TypeError(f"SklearnLearner: unexpected keyword argument {next(iter(params))!r}")
        self.spec = spec
        self.random_state = random_state
        self.action_space: spaces.Space[Any] | None = None
        self.policy: FittedPolicy | None = None

    def set_spaces(self, observation_space: spaces.Space[Any], action_space: spaces.Space[Any]):
        self.action_space = action_space

    def fit(self, observations: np.ndarray, labels: np.ndarray) -> SklearnLearner:
        labels = np.asarray(labels)
        space = self.action_space
        if space is None:
            if np.issubdtype(labels.dtype, np.integer):
                space = spaces.Discrete(int(labels.max()) + 1)
            else:
                space = spaces.Box(-np.inf, np.inf, labels.shape[1:], np.float64)
        self.policy = fit_policy(self.spec, space, observations, labels, self.random_state)
        return self

    def predict(self, observations: np.ndarray) -> np.ndarray:
        if self.policy is None:
            raise ValueError("SklearnLearner.predict: call fit first")
        return self.policy.predict(observations)

    def describe(self) -> str:
        return f"sklearn:{self.spec.name}"
