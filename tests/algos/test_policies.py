"""Policy adapters over scikit-learn: every family, Discrete and Box actions, edge cases."""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium import spaces

from fluids_bench.algos.policies import FAMILIES, MODELS, PolicySpec, fit_policy

DISCRETE = spaces.Discrete(3)
BOX = spaces.Box(-1.0, 1.0, (2,), np.float64)
BOX_1D = spaces.Box(-5.0, 5.0, (1,), np.float32)


def separable(n: int = 90) -> tuple[np.ndarray, np.ndarray]:
    """Three well separated clusters, one per class."""
    rng = np.random.default_rng(0)
    labels = np.repeat(np.arange(3), n // 3)
    X = np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]])[labels] + rng.normal(0, 0.3, (n, 2))
    return X.astype(np.float32), labels


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_classifier_family_learns_separable_classes(name: str) -> None:
    X, y = separable()
    policy = fit_policy(PolicySpec(name), DISCRETE, X, y, random_state=0)
    predicted = policy.predict(X)
    assert predicted.dtype == np.int64 and predicted.shape == (len(X),)
    assert np.mean(predicted == y) > 0.95
    assert policy.act(X[0]) == predicted[0]


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_regressor_family_fits_a_smooth_box_policy(name: str) -> None:
    rng = np.random.default_rng(1)
    X = rng.uniform(-1, 1, (120, 2))
    Y = np.clip(-0.8 * X, -1, 1)
    policy = fit_policy(PolicySpec(name), BOX, X, Y, random_state=0)
    predicted = policy.predict(X)
    assert predicted.shape == (120, 2)
    assert np.mean((predicted - Y) ** 2) < 0.05
    assert np.all(np.abs(predicted) <= 1.0)


def test_box_predictions_are_clipped_to_the_action_bounds_and_keep_the_shape() -> None:
    X = np.linspace(-1, 1, 20)[:, None]
    Y = 100.0 * X  # far outside [-5, 5]
    policy = fit_policy(PolicySpec("tree"), BOX_1D, X, Y, random_state=0)
    actions = policy.predict(X)
    assert actions.shape == (20, 1)
    assert actions.min() == -5.0 and actions.max() == 5.0


@pytest.mark.parametrize("name", FAMILIES)
def test_single_class_data_gives_that_action_everywhere(name: str) -> None:
    X = np.random.default_rng(2).normal(size=(7, 2))
    policy = fit_policy(PolicySpec(name), DISCRETE, X, np.full(7, 2), random_state=0)
    np.testing.assert_array_equal(policy.predict(np.zeros((4, 2))), [2, 2, 2, 2])


def test_constant_family_is_the_majority_vote_with_ties_to_the_lowest_action() -> None:
    X = np.zeros((6, 2))
    majority = fit_policy(PolicySpec("constant"), DISCRETE, X, np.array([1, 1, 1, 0, 0, 2]), 0)
    assert majority.act(np.ones(2)) == 1
    tie = fit_policy(PolicySpec("constant"), spaces.Discrete(2), X, np.array([1, 1, 1, 0, 0, 0]), 0)
    assert tie.act(np.ones(2)) == 0
    mean = fit_policy(
        PolicySpec("constant"), BOX, X, np.array([[0.5, -1.0]] * 3 + [[0.1, 0.0]] * 3), 0
    )
    np.testing.assert_allclose(mean.predict(np.zeros((2, 2))), [[0.3, -0.5]] * 2)
    with pytest.raises(ValueError, match="field 'params'"):
        PolicySpec("constant", {"strategy": "uniform"})


def test_knn_with_fewer_pairs_than_neighbours() -> None:
    X, y = np.array([[0.0], [1.0]]), np.array([0, 1])
    policy = fit_policy(PolicySpec("knn", {"n_neighbors": 5}), DISCRETE, X, y, 0)
    assert policy.predict(X).shape == (2,)


def test_same_random_state_same_predictions_bit_for_bit() -> None:
    X, y = separable()
    grid = np.random.default_rng(3).uniform(-2, 7, (200, 2))
    a = fit_policy(PolicySpec("mlp", {"max_iter": 50}), DISCRETE, X, y, 7).predict(grid)
    b = fit_policy(PolicySpec("mlp", {"max_iter": 50}), DISCRETE, X, y, 7).predict(grid)
    assert a.tobytes() == b.tobytes()


def test_memoised_act_agrees_with_predict_off_the_training_set() -> None:
    X, y = separable()
    policy = fit_policy(PolicySpec("linear_svm"), DISCRETE, X, y, 0)
    fresh = np.random.default_rng(4).uniform(-2, 7, (50, 2)).astype(np.float32)
    np.testing.assert_array_equal([policy.act(x) for x in fresh], policy.predict(fresh))
    np.testing.assert_array_equal([policy.act(x) for x in fresh], policy.predict(fresh))


def test_unstandardised_kernel_ridge_is_sklearns_estimator_on_the_raw_features() -> None:
    """standardize=False drops the scaler: predictions equal KernelRidge's on the raw state, and
    differ from the standardised fit (a feature of a different scale changes the RBF distances)."""
    from sklearn.kernel_ridge import KernelRidge

    rng = np.random.default_rng(2)
    X = rng.uniform(-1, 1, (80, 2)) * np.array([1.0, 20.0])
    Y = np.clip(np.column_stack([np.sin(X[:, 0]), np.cos(X[:, 1] / 20)]) * 0.9, -1, 1)
    params = {"alpha": 1e-3, "gamma": None}
    raw = fit_policy(PolicySpec("kernel_ridge", params, standardize=False), BOX, X, Y, 0)
    expected = KernelRidge(kernel="rbf", **params).fit(X, Y).predict(X)
    # (to rounding: the fitted policy predicts its training states in one batch, in another order)
    np.testing.assert_allclose(raw.predict(X), np.clip(expected, -1, 1), rtol=1e-9, atol=1e-12)
    scaled = fit_policy(PolicySpec("kernel_ridge", params), BOX, X, Y, 0)
    assert not np.allclose(scaled.predict(X), raw.predict(X))
    with pytest.raises(ValueError, match=r"field 'standardize' is 'no'; allowed: true or false"):
        PolicySpec("kernel_ridge", standardize="no")


def test_bad_specs_and_spaces_are_refused_with_what_is_allowed() -> None:
    with pytest.raises(ValueError, match=r"field 'name' is 'svm'; allowed: one of"):
        PolicySpec("svm")
    with pytest.raises(ValueError, match="max_deep"):
        PolicySpec("tree", {"max_deep": 3})
    with pytest.raises(ValueError, match="Discrete or Box"):
        fit_policy(PolicySpec(), spaces.MultiBinary(2), np.zeros((2, 1)), np.zeros((2, 2)), 0)
    with pytest.raises(ValueError, match="no training pairs"):
        fit_policy(PolicySpec(), DISCRETE, np.zeros((0, 2)), np.zeros(0), 0)


def test_tree_fast_path_equals_sklearn_predict():
    """Trees are evaluated straight through ``tree_``: same dtype, shape and values as predict."""
    from sklearn.tree import DecisionTreeClassifier, DecisionTreeRegressor

    from fluids_bench.algos.learners.sklearn import _predict

    rng = np.random.default_rng(0)
    X = rng.normal(size=(600, 12))
    targets = [
        X[:, 0] * 2 + X[:, 1],
        np.column_stack([X[:, 0], X[:, 2]]),
        (X[:, 0] > 0).astype(int) + (X[:, 1] > 0),
        rng.integers(0, 5, 600),
    ]
    for y in targets:
        cls = DecisionTreeClassifier if y.dtype.kind == "i" else DecisionTreeRegressor
        est = cls(random_state=0).fit(X[:300], y[:300])
        expected, got = est.predict(X[300:]), _predict(est, X[300:])
        assert expected.dtype == got.dtype and np.array_equal(expected, got)
