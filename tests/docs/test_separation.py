"""The leaderboard's FLUIDS separation verdicts are computed from the scorecards' intervals, and
can fail: overlapping intervals give "undecided" and "not separated"; the cards said to predate
the route-completion fix are found from git."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from script_module import load_script

GEN = Path(__file__).parents[2] / "docs" / "_gen"


@pytest.fixture()
def sep():
    return load_script(GEN / "separation.py")


def test_the_ratio_target_is_met_only_below_the_bounds_interval(sep):
    supervisor = [1.0, 1.0, 1.0]
    assert sep.ratio_verdict([0.094, 0.088, 0.101], supervisor) == "met"
    assert sep.ratio_verdict([0.203, 0.185, 0.221], supervisor) == "undecided"
    assert sep.ratio_verdict([0.25, 0.21, 0.29], supervisor) == "not met"
    # the bound's own interval counts: 0.2 x [0.9, 1.0] = [0.18, 0.2]
    assert sep.ratio_verdict([0.17, 0.16, 0.19], [0.95, 0.9, 1.0]) == "undecided"


def test_separation_needs_disjoint_intervals(sep):
    assert sep.separation([0.5, 0.4, 0.6], [0.1, 0.0, 0.2]) == "above"
    assert sep.separation([0.1, 0.0, 0.2], [0.5, 0.4, 0.6]) == "below"
    assert sep.separation([0.3, 0.2, 0.4], [0.1, 0.0, 0.25]) is None  # overlapping
    assert sep.separation([0.3, 0.2, 0.4], [0.1, 0.0, 0.2]) is None  # touching


def _card(name, driving, normalised, success=(0.0, 0.0, 0.0), episodes=500, **policy):
    return {
        "policy": {"name": name, "kind": "learner", **policy},
        "tasks": {
            "fluids": {
                "sets": {
                    "test": {
                        "episodes": episodes,
                        "driving_score": list(driving),
                        "normalised": list(normalised),
                        "success": list(success),
                    }
                }
            }
        },
        "provenance": {"git_revision": None},
    }


def test_the_page_says_undecided_and_not_separated_for_overlapping_intervals(
    sep, tmp_path, monkeypatch
):
    cards = {
        "random": _card("random", (0.21, 0.18, 0.24), (0.0, -0.01, 0.01)),
        "supervisor": _card("supervisor", (1.0, 1.0, 1.0), (1.0, 1.0, 1.0), (1, 1, 1)),
        "dagger_tree": _card("dagger_tree", (0.25, 0.22, 0.28), (0.01, 0.0, 0.02), labels_used=9),
        "ppo": _card("ppo", (0.6, 0.5, 0.7), (0.5, 0.4, 0.6), (0.4, 0.3, 0.5), env_steps=4096),
    }
    for name, card in cards.items():
        (tmp_path / f"scorecard_{name}_fluids_test.json").write_text(json.dumps(card))
    monkeypatch.setattr(sep, "RESULTS", tmp_path)
    page = sep.fluids_separation()
    assert "**Random ≤ 0.2 × supervisor: undecided.**" in page
    assert "**DAgger (tree): not separated from random** on the driving score, 0.250" in page
    assert "**PPO: separated from random (above)**" in page
    assert "(200 of 500 episodes)" in page
    assert "**BC (tree): no scorecard** (`scorecard_bc_tree_fluids_test.json`)" in page
    assert "| PPO | 500 | 0.600 [0.500, 0.700] |" in page and "| 0 (4,096 env steps) |" in page
    assert "PPO against DAgger (tree): normalised score" in page
    assert "not separated from random" in sep.fluids_separation_summary()
    (tmp_path / "scorecard_random_fluids_test.json").unlink()
    assert "No FLUIDS reference scorecard" in sep.fluids_separation()


def _has_history() -> bool:
    done = subprocess.run(
        ["git", "-C", str(GEN), "cat-file", "-e", "cc592aba102216fdb620a596ac5e5ece32370638"],
        capture_output=True,
    )
    return done.returncode == 0


needs_history = pytest.mark.skipif(not _has_history(), reason="needs the repository's history")


@needs_history
def test_the_fix_commit_is_the_route_completion_fix(sep):
    diff = subprocess.run(
        ["git", "-C", str(GEN.parents[1]), "show", sep.FIX_COMMIT, "--",
         "fluids_bench/tasks/fluids/driving_score.py"],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    assert "-    left = float(world.path_len[agent]) - float(world.s[agent] + world.offset" in diff
    assert sep.predates(sep.FIX_COMMIT) is False
    assert sep.predates(sep.FIX_COMMIT + "~1") is True
    assert sep.predates("0" * 40) is None


@needs_history
def test_regenerated_cards_are_dated_by_their_episodes_revision(sep):
    """Each EPISODES_FROM entry is the provenance revision of the card's oldest version with
    the same FLUIDS driving scores, and differs from the revision the card records."""
    for name, revision in sep.EPISODES_FROM.items():
        path = sep.RESULTS / name
        if not path.is_file():
            continue
        assert sep.oldest_same(path) == revision, name
        assert json.loads(path.read_text())["provenance"]["git_revision"] != revision


def test_the_readme_states_the_cards_fluids_numbers_and_verdict(sep):
    """README.md's FLUIDS-v4 headline (hand-written: GitHub renders no macros) holds the test
    split's driving scores and the ratio verdict the cards give, and says which learner of the
    target has no card."""
    text = (GEN.parents[1] / "README.md").read_text(encoding="utf-8")
    start = text.index("- **FLUIDS-v4 separates random from learners**")
    bullet = " ".join(text[start : text.index("\n- ", start + 1)].split())
    cards = sep.load_cards()
    random = cards["random"]["tasks"]["fluids"]["sets"]["test"]["driving_score"]
    supervisor = cards["supervisor"]["tasks"]["fluids"]["sets"]["test"]["driving_score"]
    assert (
        f"the target of at most 0.2 × the supervisor's is {sep.ratio_verdict(random, supervisor)}"
        in bullet
    )
    for name, card in cards.items():
        assert sep.number(card["tasks"]["fluids"]["sets"]["test"]["driving_score"]) in bullet, name
    for name in sep.LEARNERS:
        if name not in cards:
            assert f"{sep.NAMES[name]} has no scorecard yet" in bullet
