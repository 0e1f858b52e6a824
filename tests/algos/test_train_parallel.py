"""The algorithm layer on workers and Ray: the same records whatever runs the rollouts, bad
execution settings refused, resuming an interrupted run, and Ctrl-C with workers."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from small_fluids import SMALL_FLUIDS

from fluids_bench import cli
from fluids_bench.algos import harness as harness_module
from fluids_bench.algos.bc import BCConfig
from fluids_bench.algos.config import EXECUTION_FIELDS
from fluids_bench.algos.dagger import DAggerConfig
from fluids_bench.algos.harness import Harness
from fluids_bench.core.parallel import TaskSession, descendants, pid_alive

TIMING = ("train_seconds", "wall_seconds")
FLUIDS_ARGS = [
    "--env", SMALL_FLUIDS["env_id"],
    *[f"--env-kwarg={k}={v}" for k, v in SMALL_FLUIDS["env_kwargs"].items()],
    "--max-steps", "40", "--return-floor", "-1",
    "--policy", "tree", "--policy-param", "max_depth=10",
]  # fmt: skip
GRID_ARGS = ["--env", "GridWorld-v0", "--env-kwarg", "world_seed=3"]
ALGO_ARGS = {
    "dagger": ["--algo", "dagger", "--initial-demos", "2"],
    "dart": [
        "--algo",
        "dart",
        "--initial-demos",
        "2",
        "--update-at",
        "1",
        "2",
        "--heldout-fraction",
        "0.2",
    ],
}


@pytest.fixture(autouse=True)
def only_train(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cli, "COMMAND_MODULES", ("fluids_bench.commands.train",))


def train(out: Path, *args: str) -> int:
    return cli.main(["train", "--no-progress", "--out", str(out), *args])


def records(folder: Path) -> dict[str, Any]:
    """The one result JSON in ``folder``, without the timing fields."""
    (path,) = folder.glob("*.json")
    payload = json.loads(path.read_text())
    for record in payload["records"]:
        for name in TIMING:
            record.pop(name)
    return payload


@pytest.fixture(scope="module")
def ray_instance():
    """One local Ray instance for the module's Ray runs (starting one takes seconds)."""
    ray = pytest.importorskip("ray")
    os.environ.setdefault("RAY_AUTH_MODE", "disabled")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


@pytest.mark.parametrize("env", ["fluids", "grid"])
@pytest.mark.parametrize("algo", ["dagger", "dart"])
def test_workers_and_ray_give_the_records_of_one_process(
    algo: str, env: str, tmp_path: Path, ray_instance: Any
) -> None:
    args = [
        *(FLUIDS_ARGS if env == "fluids" else GRID_ARGS), *ALGO_ARGS[algo],
        "--iterations", "2", "--demos-per-iteration", "3", "--eval-episodes", "3",
    ]  # fmt: skip
    runs = {
        "one": [],
        "two": ["--workers", "2"],
        "ray": ["--workers", "2", "--backend", "ray"],
    }
    results = {}
    for name, extra in runs.items():
        assert train(tmp_path / name, *args, *extra) == 0
        results[name] = records(tmp_path / name)
    assert results["one"]["complete"] is True
    assert len(results["one"]["records"]) == 3
    assert results["two"] == results["one"]
    assert results["ray"] == results["one"]
    assert not list(tmp_path.glob("*/*.checkpoint"))  # a complete run leaves no checkpoint


def test_the_python_api_takes_the_execution_settings(ray_instance: Any) -> None:
    settings = {"env_id": "GridWorld-v0", "iterations": 2, "demos_per_iteration": 2}
    one = DAggerConfig(**settings)
    results = [
        dagger_records(DAggerConfig(**settings, workers=workers, backend=backend))
        for workers, backend in [(1, "process"), (2, "process"), (1, "ray")]
    ]
    assert results[0] == results[1] == results[2] == dagger_records(one)
    assert set(EXECUTION_FIELDS).isdisjoint(one.to_dict())  # not part of the records


def dagger_records(config: DAggerConfig) -> dict[str, Any]:
    from fluids_bench.algos import dagger

    return dagger.run(config).to_dict(include_timing=False)


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"workers": 0}, "BCConfig: field 'workers' is 0; allowed: an integer in [1, inf]"),
        ({"workers": 2.0}, "BCConfig: field 'workers' is 2.0; allowed: an integer"),
        ({"backend": "dask"}, "field 'backend' is 'dask'; allowed: one of ['process', 'ray']"),
        ({"address": "auto"}, "field 'address' is 'auto'; allowed: None unless backend is 'ray'"),
        ({"backend": "ray", "address": ""}, "field 'address' is ''; allowed: a Ray address"),
        ({"checkpoint": 3}, "field 'checkpoint' is 3; allowed: a folder path or None"),
    ],
)
def test_bad_execution_settings_are_refused(settings: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError) as info:
        BCConfig(**settings)
    assert message in str(info.value)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--workers", "0"], "fluids-bench train: error: --workers is 0; allowed: an integer"),
        (["--ray-address", "auto"], "--ray-address is 'auto'; allowed: None unless backend"),
    ],
)
def test_bad_cli_values_are_refused_before_any_work(
    args: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert train(tmp_path, *GRID_ARGS, "--algo", "dagger", *args) == 2
    assert message in capsys.readouterr().err
    assert not tmp_path.exists() or not list(tmp_path.iterdir())


def test_an_unknown_backend_is_an_argparse_error(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        cli.main(["train", "--env", "GridWorld-v0", "--algo", "bc", "--backend", "dask"])
    assert info.value.code == 2
    assert "argument --backend: invalid choice: 'dask'" in capsys.readouterr().err


def test_the_task_session_sends_each_batch_its_own_payload() -> None:
    got: list[list[int]] = []
    with TaskSession("process", 2) as session:
        for shared in (100, -1, 3):
            batch: dict[int, int] = {}
            session.run(max, range(6), shared, batch.__setitem__)
            got.append([batch[i] for i in range(6)])
    assert got == [[100] * 6, [0, 1, 2, 3, 4, 5], [3, 3, 3, 3, 4, 5]]


# -- resuming ---------------------------------------------------------------------------------

RESUME_ARGS = [*GRID_ARGS, "--algo", "dagger", "--iterations", "4", "--demos-per-iteration", "2",
               "--eval-episodes", "2", "--seed", "5"]  # fmt: skip


def count_rollouts(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    seeds: list[int] = []
    original = harness_module.rollout

    def spy(env, actor, seed, max_steps=None):
        seeds.append(seed)
        return original(env, actor, seed, max_steps)

    monkeypatch.setattr(harness_module, "rollout", spy)
    return seeds


def test_resume_continues_an_interrupted_run_with_the_same_records(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    assert train(tmp_path / "whole", *RESUME_ARGS) == 0
    whole = records(tmp_path / "whole")

    out = tmp_path / "cut"
    original, calls = Harness.collect_many, []

    def ctrl_c_in_iteration_3(self, actor, count):
        calls.append(count)
        if len(calls) == 4:  # initial demos, iterations 1 and 2, then Ctrl-C
            raise KeyboardInterrupt
        return original(self, actor, count)

    with monkeypatch.context() as patch:
        patch.setattr(Harness, "collect_many", ctrl_c_in_iteration_3)
        assert train(out, *RESUME_ARGS) == 130
    assert "the same command with --resume continues the run" in capsys.readouterr().err
    checkpoint = out / "dagger_GridWorld-v0_seed5.checkpoint"
    assert len(list(checkpoint.glob("record-*.pkl"))) == 3
    saved = json.loads((out / "dagger_GridWorld-v0_seed5.json").read_text())["records"]

    seeds = count_rollouts(monkeypatch)
    assert train(out, *RESUME_ARGS, "--resume") == 0
    assert f"resuming: 3 finished iterations in {checkpoint}" in capsys.readouterr().out
    assert records(out) == whole
    # the finished work is not redone: 2 rollouts for each of the 2 remaining iterations and
    # their 2 evaluations of 2 episodes
    assert len(seeds) == 2 * 2 + 2 * 2
    resumed = json.loads((out / "dagger_GridWorld-v0_seed5.json").read_text())["records"]
    assert resumed[:3] == saved  # the finished iterations keep their timing too
    assert not checkpoint.exists()

    assert train(out, *RESUME_ARGS, "--resume") == 0
    assert "complete; nothing to resume" in capsys.readouterr().out
    assert train(out, *RESUME_ARGS, "--resume", "--iterations", "5") == 2
    assert "holds a run with other settings (iterations differ)" in capsys.readouterr().err


def test_without_resume_a_run_starts_again(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    config = DAggerConfig(env_id="GridWorld-v0", iterations=2, checkpoint=str(tmp_path / "c"))
    from fluids_bench.algos import dagger

    first = dagger.run(config).to_dict(include_timing=False)
    seeds = count_rollouts(monkeypatch)
    assert dagger.run(config).to_dict(include_timing=False) == first  # all from the folder
    assert seeds == []
    # the execution settings are not part of the run: another number of workers continues it
    two = dataclasses.replace(config, workers=2)
    assert dagger.run(two).to_dict(include_timing=False) == first
    other = DAggerConfig(env_id="GridWorld-v0", iterations=3, checkpoint=str(tmp_path / "c"))
    with pytest.raises(ValueError, match=r"holds a run with other settings \(config.iterations"):
        dagger.run(other)

    assert train(tmp_path / "out", *RESUME_ARGS) == 0
    stale = tmp_path / "out" / "dagger_GridWorld-v0_seed5.checkpoint"
    stale.mkdir()
    (stale / "rollout-000000.pkl").write_bytes(b"not a rollout")
    assert train(tmp_path / "out", *RESUME_ARGS) == 0  # a new run: the folder is discarded
    assert not stale.exists()


# -- Ctrl-C with workers ----------------------------------------------------------------------


@pytest.mark.parametrize("backend", ["process", "ray"])
def test_ctrl_c_with_workers_ends_cleanly_and_keeps_the_finished_iterations(
    backend: str, tmp_path: Path
) -> None:
    if backend == "ray":
        pytest.importorskip("ray")
    process = subprocess.Popen(
        [sys.executable, "-m", "fluids_bench.cli", "train", "--no-progress",
         "--out", str(tmp_path), *FLUIDS_ARGS, "--algo", "dagger", "--iterations", "1000",
         "--demos-per-iteration", "4", "--eval-episodes", "2", "--workers", "2",
         "--backend", backend],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a shell job has
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        env={**os.environ, "RAY_AUTH_MODE": "disabled"},
    )  # fmt: skip
    path = tmp_path / f"dagger_{SMALL_FLUIDS['env_id']}_seed0.json"
    deadline = time.monotonic() + 120
    while not (path.is_file() and len(json.loads(path.read_text())["records"]) >= 2):
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline, "no iteration finished in 120 s"
        time.sleep(0.2)
    family = descendants(process.pid)
    assert len(family) >= 3  # workers and their helpers (fork server or Ray's processes)
    os.killpg(process.pid, signal.SIGINT)  # what Ctrl-C in a terminal does
    try:
        _, err = process.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        _, err = process.communicate()
        pytest.fail(f"not ended 60 s after Ctrl-C; stderr:\n{err}")
    assert process.returncode == 130, err
    # one line from fluids-bench, no traceback (Ray's own log lines aside: its start-up, and its
    # core's "[time E pid tid] file.cc:line: ..." lines, which it may print as it shuts down)
    ray_log = re.compile(r"INFO worker\.py|^\[[^]]+\] \S+\.cc:\d+:")
    lines = [line for line in err.strip().splitlines() if not ray_log.search(line)]
    assert len(lines) == 1 and lines[0].startswith("fluids-bench train: interrupted; the "), err
    assert json.loads(path.read_text())["complete"] is False
    deadline = time.monotonic() + 10
    while any(map(pid_alive, family)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [pid for pid in family if pid_alive(pid)], "orphaned worker processes"
