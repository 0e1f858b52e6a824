"""scripts/baselines/leaderboard.py: a shortened run (GridWorld, 2 episodes per set) writes valid
scorecards, a rerun does no work, and every run is the `fluids-bench train` command it states."""

from __future__ import annotations

import json

import pytest
from script_module import load_script

from fluids_bench import cli
from fluids_bench.benchmark.suite import SUITE
from fluids_bench.commands.train import build_config


def _files(root):
    return {p: (p.stat().st_mtime_ns, p.read_bytes()) for p in root.rglob("*") if p.is_file()}


def test_a_shortened_run_writes_scorecards_and_a_rerun_does_no_work(tmp_path, capsys):
    lb = load_script("baselines/leaderboard.py")
    argv = [
        "--baselines", "references", "bc", "--tasks", "gridworld", "--episodes", "2",
        "--out", str(tmp_path / "eval"), "--train-out", str(tmp_path / "train"),
        "--results", str(tmp_path / "results"), "--no-progress", "--no-plots",
    ]  # fmt: skip
    assert lb.main(argv) == 0
    cards = {
        name: json.loads((tmp_path / "results" / f"scorecard_{name}.json").read_text())
        for name in ("random", "supervisor", "bc_tree")
    }
    suite = json.loads(json.dumps(SUITE.select(2, ["gridworld"]).to_dict()))
    for card in cards.values():
        assert card["suite"] == suite and card["shortened"] and card["episodes_per_set"] == 2
        assert set(card["tasks"]["gridworld"]["sets"]) == {"test", "slippery"}
        assert all(s["episodes"] == 2 for s in card["tasks"]["gridworld"]["sets"].values())
        assert card["provenance"]["command"].startswith("python scripts/baselines/leaderboard.py")
    assert cards["random"]["tasks"]["gridworld"]["sets"]["test"]["normalised"][0] == 0.0
    assert cards["supervisor"]["tasks"]["gridworld"]["sets"]["test"]["normalised"][0] == 1.0
    bc = cards["bc_tree"]
    assert bc["policy"]["algo"] == "bc" and bc["policy"]["train_seed"] == 0
    budget = lb.BUDGET["gridworld"]
    assert 0 < bc["policy"]["labels_used"] <= budget.rollouts * budget.samples
    train = json.loads((tmp_path / "train" / "bc_tree" / "bc_GridWorld-v0_seed0.json").read_text())
    assert train["complete"] and train["config"]["iterations"] == budget.rollouts
    assert (
        bc["label_efficiency"]["gridworld"]["labels"][-1]
        == train["records"][-1]["labels_requested"]
    )

    before = _files(tmp_path)
    capsys.readouterr()

    def no_work(*args, **kwargs):
        raise AssertionError("a rerun trained or evaluated")

    real_evaluate = lb.evaluate
    lb.evaluate = lb.train = no_work
    assert lb.main(argv) == 0
    assert capsys.readouterr().out.count("is up to date") == 3
    assert _files(tmp_path) == before

    # the test split alone, from the same episodes, in its own file
    lb.evaluate = real_evaluate
    assert lb.main([*argv[:1], "references", *argv[3:], "--test-only", "--suffix", "_t"]) == 0
    card = json.loads((tmp_path / "results" / "scorecard_random_t.json").read_text())
    assert card["shortened"] and list(card["tasks"]["gridworld"]["sets"]) == ["test"]
    assert (
        card["tasks"]["gridworld"]["sets"]["test"]
        == cards["random"]["tasks"]["gridworld"]["sets"]["test"]
    )
    assert (tmp_path / "eval" / "episodes" / "random.jsonl").read_bytes() == before[
        tmp_path / "eval" / "episodes" / "random.jsonl"
    ][1]


@pytest.mark.parametrize("baseline", ["bc", "dagger", "dagger_b", "noise", "dart", "shiv"])
def test_every_run_is_the_train_command_it_states(baseline):
    lb = load_script("baselines/leaderboard.py")
    parser = cli.build_parser()
    for task in SUITE.tasks:
        args = parser.parse_args(lb.train_command(baseline, task, 3, "out/train"))
        algo, config = build_config(args)
        assert algo == lb.BASELINES[baseline].algo
        assert config.to_dict() == lb.train_config(baseline, task, 3).to_dict()


def test_every_learner_gets_the_tasks_label_budget():
    lb = load_script("baselines/leaderboard.py")
    assert set(lb.BUDGET) == {t.name for t in SUITE.tasks}
    for task in SUITE.tasks:
        budget = lb.BUDGET[task.name]
        for baseline, spec in lb.BASELINES.items():
            config = lb.train_config(baseline, task, 0)
            rollouts = config.iterations * config.demos_per_iteration + spec.initial_demos
            assert rollouts == budget.rollouts, (baseline, task.name)
            assert config.samples_per_demo == budget.samples
            assert getattr(config, "initial_demos", 0) == spec.initial_demos


@pytest.mark.train_extra
def test_ppo_is_trained_evaluated_from_its_model_and_a_finished_run_is_reused(tmp_path, capsys):
    """`--baselines ppo` on GridWorld with a one-rollout budget (4,096 steps, 1 episode per
    set): PPO trains in TRAIN_OUT/ppo in rl_baselines.py's layout, its scorecard records the
    model, a rerun does no work, and `--rl-work` evaluates a finished run without training."""
    from train_extra import require_sb3

    require_sb3()
    lb = load_script("baselines/leaderboard.py")
    lb.RL_BUDGET["gridworld"] = lb.RLBudget(steps=4096, eval_every=4096, eval_episodes=1)
    argv = [
        "--baselines", "ppo", "--tasks", "gridworld", "--episodes", "1",
        "--out", str(tmp_path / "eval"), "--train-out", str(tmp_path / "train"),
        "--results", str(tmp_path / "results"), "--no-progress", "--no-plots",
    ]  # fmt: skip
    assert lb.main(argv) == 0
    work = tmp_path / "train" / "ppo" / "GridWorld-v0" / "{}" / "ppo_s0"
    model = work / "model.zip"
    assert model.is_file()
    card = json.loads((tmp_path / "results" / "scorecard_ppo.json").read_text())
    policy = card["policy"]
    assert policy["name"] == "ppo" and policy["kind"] == "sb3" and policy["algo"] == "ppo"
    assert policy["env_id"] == "GridWorld-v0" and policy["labels_used"] == 0
    assert policy["env_steps"] >= 4096 and policy["budget_steps"] == 4096
    assert policy["model_sha256"] == lb._sha256(model)
    assert card["suite"] == json.loads(json.dumps(SUITE.select(1, ["gridworld"]).to_dict()))
    sets = card["tasks"]["gridworld"]["sets"]
    assert set(sets) == {"test", "slippery"} and all(s["episodes"] == 1 for s in sets.values())
    rows = (tmp_path / "eval" / "episodes" / "ppo.jsonl").read_text().splitlines()
    assert len(rows) == 2

    before = _files(tmp_path)
    capsys.readouterr()

    def no_work(*args, **kwargs):
        raise AssertionError("a rerun trained or evaluated")

    real_evaluate, rl = lb.evaluate, lb._rl_baselines
    lb.evaluate = lb._rl_baselines = no_work
    assert lb.main(argv) == 0
    assert capsys.readouterr().out.count("is up to date") == 1
    assert _files(tmp_path) == before

    # a finished run elsewhere (rl_baselines.py --work DIR) is evaluated, not trained again
    lb.evaluate = real_evaluate
    other = [*argv[:7], str(tmp_path / "eval2"), "--train-out", str(tmp_path / "empty"),
             "--rl-work", str(tmp_path / "train" / "ppo"), *argv[10:], "--suffix", "_t"]  # fmt: skip
    assert lb.main(other) == 0
    assert not (tmp_path / "empty").exists()
    card_t = json.loads((tmp_path / "results" / "scorecard_ppo_t.json").read_text())
    assert card_t["policy"]["model_sha256"] == policy["model_sha256"]
    assert card_t["tasks"] == card["tasks"]  # the same model on the same episodes

    # a run of more steps than the budget is not passed off as the budget's
    lb._rl_baselines = rl
    lb.RL_BUDGET["gridworld"] = lb.RLBudget(100, 100, eval_episodes=1, n_envs=1)
    with pytest.raises(ValueError, match="more than gridworld's budget"):
        lb.main(argv)


def test_ppo_has_a_budget_on_every_task_in_rl_baselines_layout():
    lb = load_script("baselines/leaderboard.py")
    assert set(lb.RL_BUDGET) == {t.name for t in SUITE.tasks}
    fluids = SUITE.task("fluids")
    # rl_baselines.py --env FLUIDS-v4 --algos ppo --seeds 0 --work W puts its run here
    assert lb.rl_work(lb.Path("W"), fluids, 0) == lb.Path("W/FLUIDS-v4/{}/ppo_s0")
    assert lb.rl_name(0) == "ppo" and lb.rl_name(2) == "ppo_seed2"
