"""Scorecard entries computed by hand, the driving score (FLUIDS-v4's info) included."""

from __future__ import annotations

import pytest

from fluids_bench.benchmark.scorecard import set_scores


def _row(ret, success=None, **extra):
    return {"return": ret, "success": success, **extra}


def test_set_scores_by_hand():
    rows = {
        "me": [
            _row(3.0, True, driving_score=0.5, route_completion=1.0, infractions={"red_light": 1}),
            _row(
                5.0,
                False,
                driving_score=0.1,
                route_completion=0.4,
                infractions={"red_light": 0, "pedestrian": 2},
            ),
        ],  # fmt: skip
        "random": [
            _row(1.0, False, driving_score=0.0, route_completion=0.1),
            _row(1.0, False, driving_score=0.2, route_completion=0.3),
        ],
        "supervisor": [
            _row(9.0, True, driving_score=1.0, route_completion=1.0),
            _row(9.0, True, driving_score=0.8, route_completion=1.0),
        ],
    }
    out = set_scores(rows, "me")
    assert out["episodes"] == 2
    assert out["random_return"] == 1.0 and out["supervisor_return"] == 9.0
    assert out["normalised"][0] == pytest.approx((4.0 - 1.0) / 8.0)
    assert out["normalised"][1] <= out["normalised"][0] <= out["normalised"][2]
    assert out["success"][0] == 0.5 and out["supervisor_success"] == 1.0
    assert out["driving_score"][0] == pytest.approx(0.3)
    assert out["random_driving_score"] == pytest.approx(0.1)
    assert out["supervisor_driving_score"] == pytest.approx(0.9)
    assert out["route_completion"] == pytest.approx(0.7)
    assert out["infractions"] == {"red_light": 0.5, "pedestrian": 1.0}  # per episode


def test_undefined_normalisation_is_reported_not_raised():
    rows = {"me": [_row(1.0)], "random": [_row(2.0)], "supervisor": [_row(2.0)]}
    out = set_scores(rows, "me")
    assert out["normalised"] is None and "undefined" in out["note"]
    assert "success" not in out  # the env reports none


def test_a_truncated_episode_without_is_success_failed():
    rows = {
        "me": [_row(1.0, True), _row(0.0, None)],  # the second hit the time limit
        "random": [_row(0.0, False), _row(0.0, False)],
        "supervisor": [_row(2.0, True), _row(2.0, True)],
    }
    out = set_scores(rows, "me")
    assert out["success"][0] == 0.5 and out["random_success"] == 0.0
