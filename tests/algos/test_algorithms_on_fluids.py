"""Every algorithm runs unchanged on FLUIDS at the velocity level (tiny budgets, short episodes)."""

from __future__ import annotations

import numpy as np
import pytest
from small_fluids import SMALL_FLUIDS

import fluids_bench  # noqa: F401
from fluids_bench.algos.policies import PolicySpec
from fluids_bench.algos.registry import ALGORITHMS, run_algorithm

FLUIDS = {
    **SMALL_FLUIDS,
    "iterations": 2,
    "eval_episodes": 1,
    "max_steps": 40,
    "return_floor": -1.0,
}


OVERRIDES = {"dagger_b": {"retrain_at": (2,)}, "dart": {"update_at": (1,), "heldout_fraction": 0.2}}


@pytest.mark.parametrize("name", sorted(ALGORITHMS))
def test_algorithm_runs_on_fluids_velocity_level(name):
    settings = {**FLUIDS, **OVERRIDES.get(name, {})}
    if name != "ogd":  # the online-gradient learner is its own linear policy
        settings["policy"] = PolicySpec("tree", {"max_depth": 10})
    result = run_algorithm(name, **settings)
    last = result.records[-1]
    assert last.labels_requested > 0
    assert np.isfinite(last.eval_return) and np.isfinite(last.collection_return)
    again = run_algorithm(name, **settings)
    assert again.records[-1].eval_return == last.eval_return  # bit for bit
