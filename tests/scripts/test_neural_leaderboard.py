"""scripts/baselines/neural_leaderboard.py: every run it launches is a valid `fluids-bench train`
command with the tree baselines' label budget (checked by building its config, nothing run)."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest
from script_module import load_script
from train_extra import require_torch

from fluids_bench.benchmark.suite import TASK_NAMES
from fluids_bench.commands import train


def _module():
    return load_script("baselines/neural_leaderboard.py")


def _config(command: list[str]):
    parser = argparse.ArgumentParser()
    train.add_parser(parser.add_subparsers())
    assert command[:2] == ["fluids-bench", "train"]
    return train.build_config(parser.parse_args(command[1:]))


@pytest.mark.train_extra
@pytest.mark.parametrize("algo", ["bc", "dagger", "dart"])
def test_every_run_is_a_train_command_with_the_same_label_budget(algo, tmp_path: Path) -> None:
    require_torch()
    nl = _module()
    assert set(nl.ORDER) == set(TASK_NAMES) == set(nl.BUDGET)
    for task in nl.ORDER:
        name, config = _config(nl.train_command(algo, task, tmp_path))
        rollouts, samples = nl.BUDGET[task]
        demos = config.iterations * config.demos_per_iteration
        assert name == algo and demos + getattr(config, "initial_demos", 0) == rollouts
        assert config.samples_per_demo == samples and config.seed == 0
        assert config.policy.spec == nl.LEARNER and config.policy.params["threads"] == 1
        assert nl.result_path(algo, task, tmp_path).name == f"{algo}_{config.env_id}_seed0.json"
