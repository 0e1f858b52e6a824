"""Scorecard plots: every card drawn, its legend entry saying how much of the suite it covers."""

from __future__ import annotations

from fluids_bench.benchmark.evaluator import evaluate
from fluids_bench.benchmark.plots import card_label, plot_scorecards
from fluids_bench.benchmark.suite import SUITE


def test_cards_of_different_coverage_are_told_apart_and_drawn(tmp_path):
    full = evaluate(
        "supervisor", SUITE.select(1, ["gridworld"]), tmp_path, progress=False, plots=False
    )
    test_only = evaluate(
        "supervisor", SUITE.select(1, ["gridworld"], ood=False), tmp_path, progress=False,
        plots=False, scorecard=tmp_path / "test_only.json",
    )  # fmt: skip
    assert card_label(full) == "supervisor (1 tasks, 1 ep/set)"
    assert card_label(test_only) == "supervisor (1 tasks, 1 ep/set, test only)"
    path = tmp_path / "cards.png"
    plot_scorecards([full, test_only], path)
    assert path.read_bytes().startswith(b"\x89PNG")
