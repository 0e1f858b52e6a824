"""Policies compared over one grid: level statistics with the episodes' standard errors, the
nominal configuration's row, and the side-by-side figure."""

from __future__ import annotations

import math

import pytest

from fluids_bench.sweep.compare import level_stats, nominal_row, plot_policies
from fluids_bench.sweep.grid import KwargGrid

GRID = KwargGrid({"a": (1, 2), "b": (0.0, 0.5)})


def _rows(successes, returns, stds, episodes=4):
    return [
        {
            "index": i,
            **c,
            "episodes": episodes,
            "successes": successes[i],
            "mean_return": returns[i],
            "std_return": stds[i],
        }
        for i, c in GRID.configurations()
    ]


def test_success_levels_pool_the_episodes_of_their_configurations():
    rows = _rows([4, 2, 0, 1], [0] * 4, [0] * 4)
    a = level_stats(rows, GRID, "success")["a"]
    assert [e["value"] for e in a] == [1, 2]
    assert a[0]["metric"] == 6 / 8 and a[0]["episodes"] == 8
    assert a[0]["stderr"] == pytest.approx(math.sqrt(0.75 * 0.25 / 8))
    assert level_stats(rows, GRID, "success")["b"][1]["metric"] == 3 / 8


def test_return_levels_average_configurations_and_carry_the_episodes_error():
    rows = _rows([0] * 4, [10.0, 20.0, 30.0, 50.0], [2.0, 4.0, 6.0, 8.0])
    b = level_stats(rows, GRID, "return")["b"]
    assert b[0]["metric"] == 20.0 and b[1]["metric"] == 35.0
    # sqrt(s1²/n + s2²/n) / 2 with n = 4 episodes each
    assert b[0]["stderr"] == pytest.approx(math.sqrt(4 / 4 + 36 / 4) / 2)
    with pytest.raises(ValueError, match="metric"):
        level_stats(rows, GRID, "speed")


def test_nominal_row_finds_the_configuration_or_none():
    rows = _rows([0] * 4, [1.0, 2.0, 3.0, 4.0], [0.0] * 4)
    assert nominal_row(rows, {"a": 2, "b": 0.0})["mean_return"] == 3.0
    assert nominal_row(rows, {"a": 3, "b": 0.0}) is None


def test_the_figure_is_a_png_and_a_return_figure_needs_its_reference(tmp_path):
    rows = _rows([4, 2, 0, 1], [10.0, 20.0, 30.0, 50.0], [2.0, 4.0, 6.0, 8.0])
    policies = {"supervisor": rows, "bc": rows[:3]}  # a partial sweep draws what is there
    path = tmp_path / "s.png"
    plot_policies(policies, GRID, "success", path, title="t")
    assert path.read_bytes().startswith(b"\x89PNG")
    with pytest.raises(ValueError, match="reference"):
        plot_policies(policies, GRID, "return", tmp_path / "r.png")
    plot_policies(policies, GRID, "return", tmp_path / "r.png", reference=20.0)
    assert (tmp_path / "r.png").stat().st_size > 1000
