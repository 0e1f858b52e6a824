"""``fluids-bench sweep`` end to end: kill mid-sweep and resume, workers, plot, errors, Ray.

A tiny grid (short episodes, one per configuration) keeps the file within seconds; the default
BC policy is trained once here on a single demonstration and passed with ``--policy``.
"""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fluids_bench.cli import main
from fluids_bench.core.parallel import import_ray
from fluids_bench.sweep.grid import Grid
from fluids_bench.sweep.run import episode_seeds, load_policy, run_sweep, train_default_policy
from fluids_bench.sweep.store import RESULTS, load_rows

# 2 x 2 x 2 = 8 configurations of one 40-step episode each
TINY = [
    "--values",
    "cars=2,3",
    "--values",
    "pedestrians=1",
    "--values",
    "lidar_noise=0.5",
    "--values",
    "lidar_dropout=0,1",
    "--values",
    "lights=on",
    "--values",
    "car_mass=750,3000",
]
TINY_ARGS = [*TINY, "--episodes", "1", "--max-episode-steps", "40", "--no-progress"]


@pytest.fixture(scope="module")
def policy_path(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("policy")
    path = train_default_policy(folder, demos=1)
    mtime = path.stat().st_mtime_ns
    assert train_default_policy(folder, demos=1) == path  # cached: not trained again
    assert path.stat().st_mtime_ns == mtime
    with pytest.raises(FileExistsError, match="other settings"):
        train_default_policy(folder, demos=2)  # refused before any training
    return path


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "fluids_bench.cli", "sweep", *args]


def _data_lines(folder: Path) -> list[str]:
    path = folder / RESULTS
    return path.read_text().splitlines()[1:] if path.exists() else []


def test_killed_sweep_resumes_to_the_uninterrupted_rows(tmp_path, policy_path, capsys):
    reference, killed = tmp_path / "reference", tmp_path / "killed"
    common = [*TINY_ARGS, "--policy", str(policy_path)]
    # uninterrupted, on a two-worker process pool
    assert main(["sweep", "--out", str(reference), "--workers", "2", *common]) == 0
    png = (reference / "sweep.png").read_bytes()
    assert png.startswith(b"\x89PNG") and len(png) < 200_000
    # one worker in another process, SIGKILLed once some rows are stored
    process = subprocess.Popen(_cli("--out", str(killed), "--workers", "1", *common))
    deadline = time.monotonic() + 60
    try:
        while not (killed / RESULTS).exists() or not load_rows(killed):
            assert time.monotonic() < deadline and process.poll() is None
            time.sleep(0.005)
    finally:
        process.kill()  # SIGKILL
        process.wait()
    assert process.returncode == -signal.SIGKILL
    stored = len(load_rows(killed))
    assert 1 <= stored < 8, "the sweep should have been killed midway"
    capsys.readouterr()
    assert main(["sweep", "--out", str(killed), "--workers", "1", *common]) == 0
    assert f"resuming: {stored} of 8" in capsys.readouterr().out
    assert load_rows(killed) == load_rows(reference)
    assert sorted(_data_lines(killed)) == sorted(_data_lines(reference))  # byte-identical rows
    assert len(_data_lines(killed)) == 8  # nothing run twice
    # a finished sweep is complete: running it again runs nothing
    assert main(["sweep", "--out", str(killed), *common]) == 0
    out = capsys.readouterr().out
    assert "resuming: 8 of 8" in out and "this run: 0 episodes" in out


def test_seeds_depend_on_the_configuration_index_only():
    assert episode_seeds(0, 3, 4) == episode_seeds(0, 3, 4)
    assert episode_seeds(0, 3, 4)[:2] == episode_seeds(0, 3, 2)
    assert len(set(episode_seeds(0, 3, 4) + episode_seeds(0, 4, 4) + episode_seeds(1, 3, 4))) == 12


def test_errors_are_reported_with_exit_code_2(tmp_path, policy_path, capsys):
    out = ["--out", str(tmp_path / "s"), "--no-progress"]
    assert main(["sweep", *out, "--values", "cars=3,2"]) == 2
    assert "increasing" in capsys.readouterr().err
    assert main(["sweep", *out, "--episodes", "0"]) == 2
    not_a_policy = tmp_path / "list.pkl"
    not_a_policy.write_bytes(__import__("pickle").dumps([1, 2]))
    assert main(["sweep", *out, *TINY, "--policy", str(not_a_policy)]) == 2
    assert "act(observation)" in capsys.readouterr().err
    # a folder holding another sweep is not mixed into
    # TINY_ARGS with one value of cars, pedestrians and lidar_dropout (a NAME given twice is
    # refused)
    args = [
        *out,
        *("--values", "cars=2", "--values", "pedestrians=0", "--values", "lidar_noise=0.5"),
        *("--values", "lidar_dropout=0", "--values", "lights=on", "--values", "car_mass=750,3000"),
        *("--episodes", "1", "--max-episode-steps", "40", "--no-progress"),
        *("--policy", str(policy_path)),
    ]
    assert main(["sweep", *args]) == 0
    assert main(["sweep", *args, "--seed", "1"]) == 2
    assert "other settings (seed)" in capsys.readouterr().err
    assert main(["sweep", *args, "--seed", "1", "--overwrite"]) == 0


def test_missing_ray_names_the_extra(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # makes `import ray` fail
    code = main(
        [
            "sweep",
            "--out",
            str(tmp_path),
            *TINY,
            "--backend",
            "ray",
            "--policy",
            "supervisor",
            "--no-progress",
        ]
    )
    assert code == 2
    assert 'pip install "fluids-bench[ray]"' in capsys.readouterr().err


def test_ray_backend_gives_the_same_rows(tmp_path, policy_path, monkeypatch):
    ray = import_ray()  # no skip: without the ray extra this fails, naming the extra
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")  # local instance: no token authentication
    grid = Grid.with_overrides(
        {
            "cars": [2, 3],
            "pedestrians": [1],
            "lidar_noise": [0.5],
            "lidar_dropout": [0.0],
            "car_mass": [1500.0],
        }
    )
    policy, data = load_policy(policy_path)
    settings = dict(episodes=2, seed=3, max_episode_steps=30)
    local = run_sweep(tmp_path / "local", grid, policy, data, **settings)
    # starts (and stops) a local Ray instance with two CPUs
    on_ray = run_sweep(tmp_path / "ray", grid, policy, data, backend="ray", workers=2, **settings)
    assert on_ray == local and len(local) == 4
    assert not ray.is_initialized()


def test_folder_of_another_sweep_is_refused_before_training(tmp_path, monkeypatch, capsys):
    out = tmp_path / "out"
    assert main(["sweep", "--out", str(out), "--policy", "supervisor", *TINY_ARGS]) == 0
    capsys.readouterr()

    def no_training(*args, **kwargs):
        raise AssertionError("trained a policy for a folder that is refused")

    monkeypatch.setattr("fluids_bench.algos.bc.run", no_training)
    # the default (trained) policy, and other settings: refused at once, nothing trained
    for extra in ([], ["--episodes", "2"]):
        assert main(["sweep", "--out", str(out), "--demos", "1", *TINY_ARGS, *extra]) == 2
        captured = capsys.readouterr()
        assert "training" not in captured.out
        err = captured.err.strip().splitlines()
        assert len(err) == 1 and "holds a sweep with other settings" in err[0], err
        assert ("episodes, policy" in err[0]) == bool(extra)
    assert not (out / "policy.pkl").exists()


def test_a_full_disk_is_one_clear_line(tmp_path, policy_path, monkeypatch, capsys):
    from fluids_bench.sweep import store

    class FullDisk:  # the store's os module, whose writes find the disk full
        def __getattr__(self, name):
            return getattr(os, name)

        @staticmethod
        def write(fd, data):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(store, "os", FullDisk())
    out = tmp_path / "full"
    assert main(["sweep", "--out", str(out), "--policy", str(policy_path), *TINY_ARGS]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "fluids-bench sweep: error: no space left on the device (No space left on device); "
        "free some space, or write elsewhere"
    ]
