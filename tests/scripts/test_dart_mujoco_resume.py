"""scripts/reproductions/reproduce_dart_mujoco.py resumes only runs made by the same command:
a finished run made with another teacher (e.g. before new weights were shipped) or another
schedule is refused by name instead of being averaged in."""

from __future__ import annotations

import json

import pytest
from script_module import load_script

TINY = [
    "--env", "Hopper-IL-v0", "--learners", "linear", "--methods", "bc", "--seeds", "1",
    "--iterations", "2", "--eval-at", "2", "--eval-episodes", "1", "--eval-steps", "20",
]  # fmt: skip


def _run(tmp_path, *extra):
    args = [*TINY, "--out", str(tmp_path / "out"), "--results", str(tmp_path / "r.json")]
    return load_script("reproductions/reproduce_dart_mujoco.py").main([*args, *extra])


def test_a_finished_run_is_reused_by_the_same_command(tmp_path):
    assert _run(tmp_path) == 0
    run = tmp_path / "out" / "runs" / "Hopper-IL-v0_linear_bc_0.json"
    before = run.read_bytes()
    assert _run(tmp_path, "--summarise-only") == 0
    assert _run(tmp_path) == 0  # nothing left to run: the file is read, not rewritten
    assert run.read_bytes() == before
    assert json.loads((tmp_path / "r.json").read_text())["summary"]


def test_a_run_made_with_other_weights_or_schedule_is_refused(tmp_path, capsys):
    assert _run(tmp_path) == 0
    run = tmp_path / "out" / "runs" / "Hopper-IL-v0_linear_bc_0.json"
    record = json.loads(run.read_text())
    record["supervisor"]["weights_sha256"] = "0" * 64  # as if made before a new teacher
    run.write_text(json.dumps(record))
    with pytest.raises(SystemExit):
        _run(tmp_path)
    err = capsys.readouterr().err
    assert str(run) in err and "another supervisor" in err and "new --out" in err


def test_a_run_made_with_another_schedule_is_refused(tmp_path, capsys):
    assert _run(tmp_path) == 0
    with pytest.raises(SystemExit):
        _run(tmp_path, "--eval-steps", "30")  # the later flag wins
    assert "another schedule" in capsys.readouterr().err
