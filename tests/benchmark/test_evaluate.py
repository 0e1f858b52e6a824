"""evaluate(policy, suite): scorecards, resume after an interruption, the policy kinds, the CLI."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from benchmark_policies import BatchOnly, Counter

from fluids_bench.benchmark.evaluator import evaluate
from fluids_bench.benchmark.suite import SUITE
from fluids_bench.cli import main
from fluids_bench.core.splits import OOD_START, TEST_START

GRID = SUITE.select(episodes=3, tasks=["gridworld"])  # 2 sets (test, slippery) x 3 episodes


def _rows(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def _run(policy, out, suite=GRID, **kw):
    return evaluate(policy, suite, out, progress=False, plots=False, **kw)


def test_references_score_zero_and_one(tmp_path):
    random_card = _run("random", tmp_path)
    supervisor_card = _run("supervisor", tmp_path)
    for card, expected in ((random_card, 0.0), (supervisor_card, 1.0)):
        for scores in card["tasks"]["gridworld"]["sets"].values():
            assert scores["normalised"][0] == expected
            assert scores["normalised"][1] <= expected <= scores["normalised"][2]
        assert card["shortened"] and card["episodes_per_set"] == 3
    sets = supervisor_card["tasks"]["gridworld"]["sets"]
    assert sets["test"]["seeds"] == {"split": "test", "first": TEST_START, "count": 3}
    assert sets["slippery"]["seeds"] == {"split": "ood", "first": OOD_START, "count": 3}
    assert sets["slippery"]["kwargs"] == {"slip_probability": 0.32}
    # the reference logs are shared: the supervisor's run reused random's rows
    assert len(_rows(tmp_path / "episodes" / "random.jsonl")) == 6
    saved = json.loads((tmp_path / "scorecard_supervisor.json").read_text())
    assert saved["suite"]["fluids_id"] == SUITE.to_dict()["fluids_id"]
    assert saved["provenance"]["packages"]["fluids-bench"]
    assert saved["aggregate"]["test"]["mean"][0] == 1.0


def test_resume_runs_only_missing_episodes(tmp_path):
    first = Counter()
    card = _run(first, tmp_path, name="zero")
    assert first.calls > 0
    again = Counter()
    assert _run(again, tmp_path, name="zero")["tasks"] == card["tasks"]
    assert again.calls == 0  # every episode was in the log
    more = Counter()
    _run(more, tmp_path, suite=SUITE.select(episodes=4, tasks=["gridworld"]), name="zero")
    rows = _rows(tmp_path / "episodes" / "zero.jsonl")
    new = [r for r in rows if r["seed"] in (TEST_START + 3, OOD_START + 3)]
    assert len(rows) == 8 and len(new) == 2
    assert more.calls == sum(r["length"] for r in new)  # only the two new episodes ran


def test_interrupted_evaluation_keeps_finished_episodes(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        _run(Counter(stop_at=70), tmp_path, name="zero")  # GridWorld episodes run 30 steps
    log = tmp_path / "episodes" / "zero.jsonl"
    kept = _rows(log)
    assert len(kept) == 2
    with log.open("a") as f:
        f.write('{"policy": "zero", "task": "grid')  # a torn last line, as a kill leaves
    resumed = Counter()
    card = _run(resumed, tmp_path, name="zero")
    assert resumed.calls == 4 * 30  # the 4 missing episodes only
    reference = _run(Counter(), tmp_path / "fresh", name="zero")
    assert card["tasks"] == reference["tasks"]  # the same scores as an uninterrupted run


def test_policy_kinds_and_workers_give_the_same_rows(tmp_path):
    by_object = _run(BatchOnly(), tmp_path / "a", name="zero")
    by_factory = _run("benchmark_policies:make_for", tmp_path / "b", name="zero")
    assert by_object["tasks"] == by_factory["tasks"]
    pooled = _run(BatchOnly(), tmp_path / "c", name="zero", workers=2)
    assert pooled["tasks"] == by_object["tasks"]
    rows = sorted(_rows(tmp_path / "c" / "episodes" / "zero.jsonl"), key=lambda r: r["seed"])
    assert rows == sorted(
        _rows(tmp_path / "a" / "episodes" / "zero.jsonl"), key=lambda r: r["seed"]
    )


def test_bad_policies_are_refused(tmp_path):
    with pytest.raises(ValueError, match="neither act"):
        _run(object(), tmp_path)
    with pytest.raises(ValueError, match="allowed: random, supervisor"):
        _run("nothing-like-a-policy", tmp_path)
    with pytest.raises(ValueError, match="no callable"):
        _run("benchmark_policies:missing", tmp_path)
    with pytest.raises(ValueError, match="is a reference's"):
        _run(Counter(), tmp_path, name="random")
    with pytest.raises(ValueError, match="unknown task"):
        SUITE.select(tasks=["chess"])
    assert main(["evaluate", "--policy", "random", "--episodes", "0"]) == 2


def test_cli_short_run(tmp_path):
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).parents[2])] + sys.path)}
    done = subprocess.run(
        [sys.executable, "-m", "fluids_bench.cli", "evaluate", "--policy", "supervisor",
         "--tasks", "gridworld", "--episodes", "2", "--out", str(out), "--no-progress"],
        capture_output=True, text=True, env=env, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "supervisor gridworld/test: normalised 1.000" in done.stdout
    card = json.loads((out / "scorecard_supervisor.json").read_text())
    assert card["provenance"]["command"].startswith("fluids-bench evaluate --policy supervisor")
    assert (out / "scorecard_supervisor.png").stat().st_size > 0


def test_a_train_result_is_rebuilt_and_gives_its_label_efficiency(tmp_path):
    assert main(
        ["train", "--env", "GridWorld-v0", "--algo", "dagger", "--iterations", "3",
         "--eval-episodes", "2", "--out", str(tmp_path / "train"), "--no-progress"]
    ) == 0  # fmt: skip
    result = tmp_path / "train" / "dagger_GridWorld-v0_seed0.json"
    card = _run(str(result), tmp_path / "eval", suite=SUITE.select(episodes=2))
    assert list(card["tasks"]) == ["gridworld"]  # only the task of the run's env
    assert card["policy"]["kind"] == "learner" and card["policy"]["algo"] == "dagger"
    records = json.loads(result.read_text())["records"]
    curve = card["label_efficiency"]["gridworld"]
    assert curve["labels"] == [float(r["labels_requested"]) for r in records]
    assert 0.0 <= curve["area"] <= 1.5
    assert curve["scores"][-1] == pytest.approx(
        (records[-1]["eval_return"] - card["policy"]["learning_curve"]["random_return"])
        / (json.loads(result.read_text())["supervisor_return"]
           - card["policy"]["learning_curve"]["random_return"])
    )  # fmt: skip
    with pytest.raises(ValueError, match="was trained on GridWorld-v0"):
        _run(str(result), tmp_path / "eval", suite=SUITE.select(episodes=2, tasks=["hopper"]))


def test_a_train_results_learner_is_rebuilt_only_when_episodes_are_missing(tmp_path, monkeypatch):
    from fluids_bench.algos.registry import get_algorithm
    from fluids_bench.benchmark import policies

    assert main(
        ["train", "--env", "GridWorld-v0", "--algo", "bc", "--iterations", "2",
         "--eval-episodes", "2", "--out", str(tmp_path / "train"), "--no-progress"]
    ) == 0  # fmt: skip
    path = tmp_path / "train" / "bc_GridWorld-v0_seed0.json"
    suite = SUITE.select(episodes=2, tasks=["gridworld"])
    lazy = policies.train_result_source(path)
    assert lazy.obj is None and lazy.extras["labels_used"] > 0
    calls = []
    real = policies._train_again  # noqa: SLF001
    monkeypatch.setattr(policies, "_train_again", lambda *a: calls.append(a) or real(*a))
    first = _run(str(path), tmp_path / "eval", suite=suite)
    assert len(calls) == 1  # its episodes were missing: rebuilt once
    again = _run(str(path), tmp_path / "eval", suite=suite)
    assert len(calls) == 1 and again["tasks"] == first["tasks"]  # all there: not rebuilt
    # a caller holding the run's result passes it: the same source, nothing run again
    data = json.loads(path.read_text())
    result = get_algorithm("bc").run(policies._train_config(path, data), None)  # noqa: SLF001
    held = policies.train_result_source(path, "bc_held", result)
    assert held.obj is result.policy and held.extras == lazy.extras
    card = _run({"gridworld": held}, tmp_path / "eval2", suite=suite, name="bc_held")
    assert len(calls) == 1
    assert card["tasks"]["gridworld"]["sets"] == first["tasks"]["gridworld"]["sets"]


def test_train_runs_evaluation_seeds_are_the_harness_ones():
    from fluids_bench.algos.harness import Harness, RunConfig
    from fluids_bench.benchmark.policies import harness_eval_seeds

    config = RunConfig(env_id="GridWorld-v0", eval_episodes=4, seed=7)
    with Harness("bc", config) as harness:
        assert harness.eval_seeds == harness_eval_seeds(config)


@pytest.mark.train_extra
def test_an_sb3_model_file(tmp_path):
    from train_extra import require_sb3

    sb3 = require_sb3()
    import gymnasium as gym

    model = sb3.PPO("MlpPolicy", gym.make("GridWorld-v0"), n_steps=32, batch_size=32, seed=0)
    model.learn(32)
    path = tmp_path / "ppo_gridworld.zip"
    model.save(path)
    card = _run(str(path), tmp_path / "eval", suite=SUITE.select(episodes=1, tasks=["gridworld"]))
    assert card["policy"]["kind"] == "sb3" and card["policy"]["name"] == "ppo_gridworld"
    assert card["tasks"]["gridworld"]["sets"]["test"]["episodes"] == 1
    with pytest.raises(ValueError, match="does not record its env"):
        _run(str(path), tmp_path / "eval", suite=SUITE.select(episodes=1))
