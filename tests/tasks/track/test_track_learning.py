"""What the ch. 6 reproductions on DrivingTrack rest on: the span-solved linear SVM is the same
model as scikit-learn's LinearSVC, the One-Class SVM on a precomputed kernel is libsvm's own, and
the source's bandwidths mapped to the track's HOG scale mean what the source's do."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import LinearSVC, OneClassSVM

import fluids_bench  # noqa: F401
from fluids_bench.algos.policies import SpanLinearSVC, distinct_rows
from fluids_bench.algos.query import _LevelSet, gamma_of
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.tasks.track.bandwidth import median_state_distance, source_sigma


def wide_data(classes: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """HOG-like rows: far more features than rows, sparse, non-negative, with exact repeats."""
    rng = np.random.default_rng(seed)
    base = rng.random((40, 600)) * (rng.random((40, 600)) < 0.15)
    y = rng.integers(classes, size=40)
    repeats = rng.integers(40, size=25)  # 25 exact repeats of (state, label) pairs
    return np.vstack([base, base[repeats]]), np.concatenate([y, y[repeats]])


def weighted_reference(X: np.ndarray, y: np.ndarray, C: float, **kw) -> object:
    """scikit-learn's pipeline on the distinct pairs, each weighted by its count."""
    keys = [row.tobytes() + bytes([label]) for row, label in zip(X, y, strict=True)]
    first = {k: i for i, k in reversed(list(enumerate(keys)))}
    order = sorted(first.values())
    counts = np.array([keys.count(keys[i]) for i in order], dtype=float)
    model = make_pipeline(StandardScaler(), LinearSVC(C=C, random_state=0, **kw))
    return model.fit(
        X[order], y[order], standardscaler__sample_weight=counts, linearsvc__sample_weight=counts
    )


@pytest.mark.parametrize("classes", [2, 3])
def test_span_linear_svm_is_linear_svc_on_standardised_features(classes: int) -> None:
    X, y = wide_data(classes)
    probe = np.random.default_rng(1).random((30, 600)) * 0.5
    span = SpanLinearSVC(C=0.01, random_state=0, tol=1e-10, max_iter=100_000).fit(X, y)
    # same dual problem, same coordinate order: the same solution to rounding
    same = weighted_reference(X, y, 0.01, tol=1e-10, max_iter=100_000)
    np.testing.assert_allclose(
        span.decision_function(probe), same.decision_function(probe), atol=1e-7
    )
    # and the repeated rows as they are (another dual, the same optimum)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        plain = make_pipeline(
            StandardScaler(), LinearSVC(C=0.01, random_state=0, tol=1e-10, max_iter=100_000)
        ).fit(X, y)
    np.testing.assert_allclose(
        span.decision_function(probe), plain.decision_function(probe), atol=1e-5
    )
    np.testing.assert_array_equal(span.predict(probe), plain.predict(probe))
    np.testing.assert_array_equal(span.classes_, np.unique(y))


def test_distinct_rows_keeps_first_occurrences_in_order() -> None:
    X = np.array([[1.0, 2.0], [3.0, 4.0], [1.0, 2.0], [5.0, 6.0], [3.0, 4.0]], dtype=np.float32)
    np.testing.assert_array_equal(distinct_rows(X), [0, 1, 3])


@pytest.mark.parametrize("sigma", [0.3, 1.0, 5.0])
def test_level_set_on_a_precomputed_kernel_is_libsvms_own(sigma: float) -> None:
    X, _ = wide_data(2)
    probe = np.vstack([X[:10], np.random.default_rng(2).random((20, 600)) * 0.3])
    own = OneClassSVM(nu=0.1, gamma=gamma_of(sigma)).fit(X)
    level_set = _LevelSet(0.1, sigma).fit(X)
    np.testing.assert_array_equal(level_set.model.support_, own.support_)
    np.testing.assert_allclose(level_set.decision(probe), own.decision_function(probe), atol=1e-9)
    # a repeated training state sits exactly where libsvm puts it (k(x, x) = 1, not 1 - 1e-15)
    few = X[:3]
    np.testing.assert_array_equal(
        _LevelSet(1e-3, sigma).fit(few).decision(few) >= 0.0,
        OneClassSVM(nu=1e-3, gamma=gamma_of(sigma)).fit(few).decision_function(few) >= 0.0,
    )


def demonstration_states(track_seed: int) -> np.ndarray:
    env = gym.make("DrivingTrack-Source-v0", track_seed=track_seed)
    obs, info = env.reset(seed=5)
    states = [obs]
    for _ in range(60):
        obs, *_, info = env.step(info[SUPERVISOR_ACTION_KEY])
        states.append(obs)
    env.close()
    return np.array(states)


def off_diagonal_kernel(states: np.ndarray, sigma: float) -> np.ndarray:
    X = states[distinct_rows(states)].astype(np.float64)
    squared = ((X[:, None] - X[None]) ** 2).sum(-1)[np.triu_indices(len(X), k=1)]
    return np.exp(-squared / (2 * sigma**2))


def test_source_sigmas_on_the_hog_scale_mean_what_the_source_says() -> None:
    states = demonstration_states(3)
    scale = median_state_distance(states)
    assert 0.3 < scale < 5.0  # HOG distances on a track: order 1, not the source's hundreds
    # the anchor: the source's grid-searched 200 is the median heuristic (median kernel e^-1/2)
    assert source_sigma(200, scale) == pytest.approx(scale)
    assert np.median(off_diagonal_kernel(states, source_sigma(200, scale))) == pytest.approx(
        np.exp(-0.5), abs=0.03
    )
    # sigma = 1 "asks for everything": no two distinct states are similar
    assert off_diagonal_kernel(states, source_sigma(1, scale)).max() < 1e-6
    # sigma = 350: most pairs look alike
    assert np.median(off_diagonal_kernel(states, source_sigma(350, scale))) > 0.8
    # the source's numbers used raw: every pair alike already at 50
    assert off_diagonal_kernel(states, 50.0).min() > 0.99
    # the ratios between the source's values are kept
    assert source_sigma(350, scale) / source_sigma(150, scale) == pytest.approx(350 / 150)


def test_bandwidth_mapping_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="sigma_source"):
        source_sigma(0.0, 1.0)
    with pytest.raises(ValueError, match="scale"):
        source_sigma(200.0, float("nan"))
    with pytest.raises(ValueError, match="states"):
        median_state_distance(np.ones((4, 10)))
