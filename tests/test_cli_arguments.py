"""Bad arguments on the command line end with one clear line and exit code 2, no traceback."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from fluids_bench.cli import main


def _cli(tmp_path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "MINARI_DATASETS_PATH": str(tmp_path / "minari")}
    return subprocess.run(
        [sys.executable, "-m", "fluids_bench.cli", *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
        timeout=300,
    )


@pytest.mark.parametrize(
    ("env_id", "kwarg", "message"),
    [
        ("FLUIDS-v0", "action_levle=velocity", "FluidsEnv: unknown argument(s) 'action_levle'"),
        ("GridWorld-v0", "sise=3", "GridWorldEnv: unknown argument(s) 'sise'"),
    ],
)
def test_misspelled_env_kwarg_is_one_line(tmp_path, env_id, kwarg, message):
    out = _cli(
        tmp_path,
        "collect",
        "--env",
        env_id,
        "--episodes",
        "2",
        "--dataset",
        "test/bad-v0",
        "--env-kwarg",
        kwarg,
        "--no-progress",
    )
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], out.stderr
    assert "Traceback" not in out.stderr


def test_negative_seed_is_refused_before_anything_runs(tmp_path):
    out = _cli(tmp_path, "demo", "--seed", "-2", "--steps", "5", "--out", str(tmp_path / "d"))
    assert out.returncode == 2
    assert out.stderr.strip().splitlines() == [
        "fluids-bench demo: error: --seed is -2; allowed: an integer in [0, 4294967295]"
    ]
    assert not (tmp_path / "d.mp4").exists()


@pytest.mark.parametrize(
    "args",
    [
        ["collect", "--env", "DAG-v0", "--episodes", "1", "--dataset", "test/x-v0", "--seed", "-1"],
        ["train", "--env", "GridWorld-v0", "--algo", "bc", "--seed", "-5", "--out", "o"],
        ["sweep", "--train-seed", "-1", "--out", "o"],
    ],
)
def test_negative_seeds_name_the_option(tmp_path, capsys, monkeypatch, args):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    option = next(a for a in args if a.endswith("seed"))
    assert len(err) == 1 and f"{option} is -" in err[0], err
    assert not (tmp_path / "o").exists()
