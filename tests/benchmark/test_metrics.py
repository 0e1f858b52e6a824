"""The benchmark's metrics against values computed by hand."""

from __future__ import annotations

import numpy as np
import pytest

from fluids_bench.benchmark import metrics


def test_normalised_scores_by_hand():
    # random's mean 1, supervisor's mean 5: (R - 1) / 4
    scores = metrics.normalised_scores([1.0, 3.0, 5.0, 7.0], [0.0, 2.0], [4.0, 6.0])
    assert scores.tolist() == [0.0, 0.5, 1.0, 1.5]
    with pytest.raises(ValueError, match="does not exceed"):
        metrics.normalised_scores([1.0], [2.0], [2.0])
    with pytest.raises(ValueError, match="at least one episode"):
        metrics.normalised_scores([], [0.0], [1.0])


def test_interval_brackets_the_mean_and_is_reproducible():
    values = [0.0, 1.0] * 50
    mean, low, high = metrics.interval(values)
    assert mean == 0.5
    assert low < 0.5 < high
    # the mean of 100 coin flips: the 95 % interval is about 0.5 +- 1.96 * 0.05
    assert 0.17 < high - low < 0.23
    assert metrics.interval(values) == (mean, low, high)
    state = np.random.get_state()  # noqa: NPY002
    metrics.interval(values)
    assert np.array_equal(np.random.get_state()[1], state[1])  # noqa: NPY002  (left as it was)
    assert metrics.interval([2.5]) == (2.5, 2.5, 2.5)


def test_run_matrix_groups_episodes_into_equal_runs():
    matrix = metrics.run_matrix({"a": [1.0, 2.0, 3.0, 4.0], "b": [10.0, 20.0]})
    # b has 2 episodes: a's 4 become 2 runs of 2 episodes each
    assert matrix.tolist() == [[1.5, 10.0], [3.5, 20.0]]


def test_iqm_by_hand():
    # 8 cells: the IQM drops the lowest 2 and the highest 2 and averages the middle 4
    matrix = np.array([[0.0, 100.0], [1.0, 2.0], [3.0, 4.0], [-50.0, 5.0]])
    assert metrics.iqm(matrix) == pytest.approx((1.0 + 2.0 + 3.0 + 4.0) / 4)


def test_aggregate_mean_and_iqm_with_intervals():
    per_task = {"a": [0.0, 0.2, 0.4, 0.6], "b": [1.0, 1.0, 1.0, 1.0]}
    out = metrics.aggregate(per_task)
    assert out["runs"] == 4 and out["tasks"] == ["a", "b"]
    mean, low, high = out["mean"]
    assert mean == pytest.approx((0.3 + 1.0) / 2)
    assert low <= mean <= high
    # IQM of the 8 cells [0, .2, .4, .6, 1, 1, 1, 1]: middle four .4, .6, 1, 1
    assert out["iqm"][0] == pytest.approx(0.75)
    assert out["iqm"][1] <= 0.75 <= out["iqm"][2]
    # stratified: task b never varies, so the interval comes from a's spread alone
    assert high - low < 0.3


def test_label_efficiency_area_by_hand():
    curve = metrics.label_efficiency([100, 0, 300], [0.5, 0.0, 1.0])
    assert curve["labels"] == [0.0, 100.0, 300.0]
    # trapezoids: 100 * 0.25 + 200 * 0.75 = 175, over 300 labels
    assert curve["area"] == pytest.approx(175 / 300)
    # to a budget past the last point: held at 1.0 for 100 more labels
    assert metrics.label_efficiency([0, 100, 300], [0.0, 0.5, 1.0], budget=400)["area"] == (
        pytest.approx((175 + 100) / 400)
    )
    # to a budget inside the curve: interpolated (0.25 at 50 labels)
    assert metrics.label_efficiency([0, 100], [0.0, 0.5], budget=50)["area"] == pytest.approx(0.125)
    assert metrics.label_efficiency([10], [0.7])["area"] == 0.7
    with pytest.raises(ValueError, match="repeat"):
        metrics.label_efficiency([1, 1], [0.0, 1.0])
    with pytest.raises(ValueError, match="budget"):
        metrics.label_efficiency([10, 20], [0.0, 1.0], budget=5)
