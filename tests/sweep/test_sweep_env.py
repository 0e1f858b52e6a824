"""``fluids-bench sweep --env``: the sweep on FLUIDS-Sensitivity-v1, and BC's in-distribution check.

One tiny grid (two configurations, one 40-step episode each) keeps this within seconds.
"""

from __future__ import annotations

import json

import pytest

from fluids_bench.cli import main
from fluids_bench.sweep.grid import Grid
from fluids_bench.sweep.run import (
    in_distribution_check,
    probe_env,
    train_default_policy,
)
from fluids_bench.sweep.store import ResultStore

TINY = [
    *("--values", "cars=2,3", "--values", "pedestrians=1", "--values", "lidar_noise=0"),
    *("--values", "lidar_dropout=0", "--values", "lights=on", "--values", "car_mass=1500"),
    *("--episodes", "1", "--max-episode-steps", "40", "--no-progress"),
]


def test_env_option_runs_v1_and_records_it(tmp_path):
    out = tmp_path / "v1"
    args = ["sweep", "--out", str(out), "--policy", "supervisor", *TINY]
    assert main([*args, "--env", "FLUIDS-Sensitivity-v1"]) == 0
    assert ResultStore(out).read_manifest()["env_id"] == "FLUIDS-Sensitivity-v1"
    # the same folder under the v0 env is another sweep: refused, not mixed
    assert main(args) == 2


def test_the_source_parameters_belong_to_the_sensitivity_ids(tmp_path, capsys):
    # on another id, --values name that env's kwargs: cars, pedestrians, ... are not FLUIDS-v1's
    args = ["sweep", "--out", str(tmp_path), "--policy", "supervisor", *TINY]
    assert main([*args, "--env", "FLUIDS-v1"]) == 2
    err = capsys.readouterr().err
    assert "'cars'" in err and "'env'" in err and "FLUIDS-Sensitivity-v1" in err
    assert not (tmp_path / "results.csv").exists()  # refused before any work
    with pytest.raises(ValueError, match="'env'"):
        probe_env(Grid.default(), "CartPole-v1")


def test_training_records_the_in_distribution_success(tmp_path):
    path = train_default_policy(tmp_path, demos=1, env_id="FLUIDS-Sensitivity-v1", check_episodes=2)
    info = json.loads((tmp_path / "policy.json").read_text())
    check = info["in_distribution"]
    assert check["episodes"] == 2
    assert check["successes"] + check["collisions"] + check["timeouts"] == 2
    assert info["settings"]["config"]["env_id"] == "FLUIDS-Sensitivity-v1"
    # cached: a larger check on the same policy is added without retraining
    mtime = path.stat().st_mtime_ns
    train_default_policy(tmp_path, demos=1, env_id="FLUIDS-Sensitivity-v1", check_episodes=3)
    assert path.stat().st_mtime_ns == mtime
    assert json.loads((tmp_path / "policy.json").read_text())["in_distribution"]["episodes"] == 3


def test_supervisor_succeeds_in_distribution_on_v1():
    check = in_distribution_check("FLUIDS-Sensitivity-v1", None, 3)
    assert check == {**check, "episodes": 3, "successes": 3, "success_rate": 1.0}


def test_train_kwargs_change_the_demonstrations_and_are_recorded(tmp_path, capsys):
    noisy = train_default_policy(
        tmp_path / "noisy", demos=1, env_id="FLUIDS-Sensitivity-v1",
        train_kwargs={"lidar_noise": 1.0},
    )  # fmt: skip
    clean = train_default_policy(tmp_path / "clean", demos=1, env_id="FLUIDS-Sensitivity-v1")
    info = json.loads((tmp_path / "noisy" / "policy.json").read_text())
    assert info["settings"]["config"]["env_kwargs"] == {"lidar_noise": 1.0}
    assert noisy.read_bytes() != clean.read_bytes()  # same seed, other observations
    out = tmp_path / "cli"
    args = ["sweep", "--out", str(out), "--env", "FLUIDS-Sensitivity-v1", "--demos", "1", *TINY]
    assert main([*args, "--train-kwarg", "no_such_option=1"]) == 2
    assert "no_such_option" in capsys.readouterr().err
