"""scripts/quality/supervisor_quality.py --env: a benchmark id's ego supervisor per condition
(tiny runs: one validation seed each), and its summary's intervals."""

from __future__ import annotations

import pytest
from script_module import load_script

from fluids_bench.core.splits import split_seeds


@pytest.fixture(scope="module")
def sq():
    return load_script("quality/supervisor_quality.py")


@pytest.mark.parametrize("condition", ["supervisor", "noisy", "background"])
def test_each_condition_scores_the_ego(sq, condition):
    seed = split_seeds("validation", 1)[0]
    row = sq._episode(("FLUIDS-v4", condition, seed, 0.01, 0.1))
    assert row["condition"] == condition and row["seed"] == seed
    assert 0.0 <= row["driving_score"] <= row["route_completion"] <= 1.0
    assert set(row["infractions"]) >= {"offroad", "vehicle_collisions", "timeouts"}
    if condition == "supervisor":
        assert row["success"] and row["driving_score"] == 1.0


def test_summary_intervals(sq):
    rows = [
        {"seed": s, "success": s < 3, "driving_score": 1.0 if s < 3 else 0.5,
         "route_completion": 1.0, "infractions": {"offroad": int(s >= 3)}}
        for s in range(4)
    ]  # fmt: skip
    out = sq.summarise(rows)
    assert out["success"] == 3 and out["success_rate"] == 0.75
    low, high = out["success_ci"]
    assert 0.0 < low < 0.75 < high < 1.0  # Wilson: inside (0, 1), around the rate
    assert out["driving_score"] == pytest.approx(0.875)
    assert out["driving_score_ci"][0] <= 0.875 <= out["driving_score_ci"][1]
    assert out["infractions"] == {"offroad": 1} and out["failed_seeds"] == [3]
