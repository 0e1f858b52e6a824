"""Gymnasium's "-v0 is out of date" advice is silenced for our deliberate v0 ids only."""

from __future__ import annotations

import warnings

import gymnasium as gym

import fluids_bench  # noqa: F401  (registers the ids)


def _out_of_date(env_id: str) -> list[str]:
    # record=True keeps the active filters (pytest's, from pyproject.toml) and only collects
    with warnings.catch_warnings(record=True) as caught:
        gym.make(env_id).close()
    return [str(w.message) for w in caught if "is out of date" in str(w.message)]


def test_fluids_v0_makes_without_the_out_of_date_warning() -> None:
    assert _out_of_date("FLUIDS-v0") == []
    assert _out_of_date("FLUIDS-Sensitivity-v0") == []


def test_other_ids_still_get_gymnasiums_advice() -> None:
    # the filter names our ids only: Gymnasium's own superseded ids still warn
    assert any("CartPole-v0" in m for m in _out_of_date("CartPole-v0"))
