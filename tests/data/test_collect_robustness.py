"""``fluids-bench collect`` under the things that go wrong in real use: an existing dataset,
SIGKILL during export or of a worker pool, Ctrl-C, a full disk. Real subprocesses and signals
where the defect is about processes."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pyarrow.dataset
import pytest

from fluids_bench.cli import main
from fluids_bench.core.parallel import descendants, pid_alive
from fluids_bench.data import minari_export
from fluids_bench.data.minari_export import STAGING_DIR


@pytest.fixture(autouse=True)
def datasets_root(tmp_path, monkeypatch) -> Path:
    root = tmp_path / "minari"
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))
    monkeypatch.chdir(tmp_path)
    return root


def _collect_args(dataset: str, *extra: str, env: str = "DAG-v0", episodes: int = 3) -> list:
    return ["collect", "--env", env, "--episodes", str(episodes), "--dataset", dataset,
            "--no-progress", *extra]  # fmt: skip


def _spawn(args: list[str], capture: bool = True) -> subprocess.Popen:
    # orphans would hold captured pipes open: a test that expects none does not capture
    out = subprocess.PIPE if capture else subprocess.DEVNULL
    return subprocess.Popen(
        [sys.executable, "-m", "fluids_bench.cli", *args],
        stdout=out,
        stderr=out,
        text=True,
        start_new_session=True,  # its own process group, as a shell job has
        # Ctrl-C's default action, as in a terminal: a runner started in the background (a
        # non-interactive shell's `&` job) ignores SIGINT, and children inherit that
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def _wait_for_workers(process: subprocess.Popen, count: int, timeout: float = 90) -> list[int]:
    """The process's descendants once ``count`` exist (resource tracker, fork server, workers)."""
    deadline = time.monotonic() + timeout
    while len(found := descendants(process.pid)) < count:
        assert process.poll() is None, "the command ended early"
        assert time.monotonic() < deadline, "the worker pool did not start"
        time.sleep(0.1)
    return found


def test_an_existing_dataset_is_refused_before_collecting(monkeypatch, capsys):
    assert main(_collect_args("test/exists-v0")) == 0
    capsys.readouterr()

    def no_collecting(*args, **kwargs):
        raise AssertionError("collected although the dataset exists")

    monkeypatch.setattr("fluids_bench.data.collect.collect", no_collecting)
    assert main(_collect_args("test/exists-v0")) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'test/exists-v0' already exists" in err[0], err


def test_staging_left_by_a_sigkilled_export_is_removed_by_the_next(datasets_root):
    # a real export, SIGKILLed by itself once Minari has written its files into staging
    script = textwrap.dedent(
        """
        import os, signal, sys
        import minari
        from fluids_bench.cli import main
        create = minari.create_dataset_from_buffers
        def create_then_die(*args, **kwargs):
            create(*args, **kwargs)
            os.kill(os.getpid(), signal.SIGKILL)
        minari.create_dataset_from_buffers = create_then_die
        main(sys.argv[1:])
        """
    )
    killed = subprocess.run(
        [sys.executable, "-c", script, *_collect_args("test/killed-v0")],
        capture_output=True,
        text=True,
    )
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    staging = datasets_root / STAGING_DIR
    left = list(staging.iterdir())
    assert len(left) == 1 and any(left[0].rglob("*")), "the kill left no staging to clean"
    live = staging / f"{os.uname().nodename}.{os.getpid()}.0123abcd"  # a live export: kept
    live.mkdir()

    assert main(_collect_args("test/next-v0")) == 0
    assert [p.name for p in staging.iterdir()] == [live.name]
    assert not (datasets_root / "test" / "killed-v0").exists()
    assert (datasets_root / "test" / "next-v0").is_dir()


def test_sigkill_of_collect_with_workers_leaves_no_process_behind():
    process = _spawn(_collect_args("test/orphans-v0", "--workers", "2", env="FLUIDS-v0",
                                   episodes=500), capture=False)  # fmt: skip
    family: list[int] = []
    try:
        family = _wait_for_workers(process, 4)
        time.sleep(1.0)  # the workers are in episodes
        process.kill()  # SIGKILL: no clean-up runs in the parent
        process.wait()
        deadline = time.monotonic() + 15
        while any(map(pid_alive, family)) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not [pid for pid in family if pid_alive(pid)], "orphaned worker processes"
    finally:
        for pid in family:
            if pid_alive(pid):
                os.kill(pid, signal.SIGKILL)


@pytest.mark.parametrize("workers", [1, 2])
def test_ctrl_c_ends_with_one_line_and_exit_code_130(workers):
    process = _spawn(_collect_args("test/interrupted-v0", "--workers", str(workers),
                                   env="FLUIDS-v0", episodes=500))  # fmt: skip
    family = _wait_for_workers(process, 4 if workers > 1 else 0)
    time.sleep(4.0 if workers == 1 else 1.0)  # well into the episodes (compiled kernels running)
    os.killpg(process.pid, signal.SIGINT)  # what Ctrl-C in a terminal does
    try:
        _, err = process.communicate(timeout=60)
    except subprocess.TimeoutExpired:  # say where it stood, then clean up
        alive = [pid for pid in [process.pid, *family] if pid_alive(pid)]
        os.killpg(process.pid, signal.SIGKILL)
        _, err = process.communicate()
        pytest.fail(f"not ended 60 s after Ctrl-C; processes alive: {alive}; stderr:\n{err}")
    assert process.returncode == 130, err
    lines = err.strip().splitlines()  # finished episodes are kept (test_collect_interrupt.py)
    assert lines[-1] == "fluids-bench collect: interrupted", err
    assert all(line.startswith("fluids-bench collect: kept ") for line in lines[:-1]), err
    assert len(lines) <= 2, err
    deadline = time.monotonic() + 10
    while any(map(pid_alive, family)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [pid for pid in family if pid_alive(pid)]


def test_a_full_disk_is_one_clear_line(monkeypatch, capsys, datasets_root):
    def disk_full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), "episode_0.arrow")

    monkeypatch.setattr(pyarrow.dataset, "write_dataset", disk_full)  # what Minari writes with
    assert main(_collect_args("test/full-v0")) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "fluids-bench collect: error: no space left on the device writing episode_0.arrow "
        "(No space left on device); free some space, or write elsewhere"
    ]
    assert not (datasets_root / "test" / "full-v0").exists()
    assert not (datasets_root / STAGING_DIR).exists()  # nothing half-written is left
    assert minari_export.remove_stale_staging(datasets_root) == []


def test_hdf5_without_h5py_is_refused_before_collecting(monkeypatch, capsys):
    import importlib.util

    find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "h5py" else find_spec(name, *a),
    )

    def no_collecting(*args, **kwargs):
        raise AssertionError("collected although the dataset cannot be written")

    monkeypatch.setattr("fluids_bench.data.collect.collect", no_collecting)
    assert main(_collect_args("test/hdf5-v0", "--data-format", "hdf5")) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        'fluids-bench collect: error: data_format "hdf5" needs h5py: '
        'pip install "fluids-bench[hdf5]"'
    ]


def test_measured_reference_scores_are_stored_and_others_left_out(capsys):
    import minari

    from fluids_bench.tasks.locomotion.env import RANDOM_RETURN, SUPERVISOR_RETURN

    argv = _collect_args("test/hopper-v0", "--max-steps", "5", env="Hopper-IL-v0", episodes=1)
    assert main(argv) == 0
    meta = minari.load_dataset("test/hopper-v0").storage.metadata
    assert (meta["ref_min_score"], meta["ref_max_score"]) == (
        RANDOM_RETURN["Hopper"],
        SUPERVISOR_RETURN["Hopper"],
    )
    # another supervisor than the measured one: no reference scores
    argv = _collect_args(
        "test/hopper-mpc-v0", "--max-steps", "2", "--env-kwarg", "supervisor=mpc",
        env="Hopper-IL-v0", episodes=1,
    )  # fmt: skip
    assert main(argv) == 0
    assert minari.load_dataset("test/hopper-mpc-v0").storage.metadata.get("ref_min_score") is None
    assert main(_collect_args("test/dag-v0")) == 0  # no measured scores for DAG
    meta = minari.load_dataset("test/dag-v0").storage.metadata
    assert meta.get("ref_min_score") is None and meta.get("ref_max_score") is None
    # given ones win
    argv = _collect_args("test/dag-ref-v0", "--ref-min-score", "-1", "--ref-max-score", "2")
    assert main(argv) == 0
    meta = minari.load_dataset("test/dag-ref-v0").storage.metadata
    assert (meta["ref_min_score"], meta["ref_max_score"]) == (-1.0, 2.0)


def test_a_concurrent_collect_into_the_same_id_is_refused(monkeypatch, capsys, datasets_root):
    # the race, deterministically: while the first run collects, a second run into the same
    # new id starts and runs to its end (as another process would)
    import minari

    from fluids_bench.data import collect as collect_module

    collect, second = collect_module.collect, []

    def collect_while_another_run_starts(*args, **kwargs):
        second.append(main(_collect_args("test/race-v0", "--seed", "50", episodes=2)))
        return collect(*args, **kwargs)

    monkeypatch.setattr(collect_module, "collect", collect_while_another_run_starts)
    assert main(_collect_args("test/race-v0", episodes=3)) == 0
    assert second == [2]
    err = capsys.readouterr().err
    assert "dataset 'test/race-v0' is being written by process" in err, err
    assert minari.load_dataset("test/race-v0").total_episodes == 3  # the first run's data
    assert not (datasets_root / ".fluids-bench-claims").exists()  # the claim is released


def test_a_dataset_that_appears_during_an_export_is_never_replaced(datasets_root):
    # the last line of defence, under the claim: the final rename refuses an existing dataset
    import minari

    from fluids_bench.data.collect import collect
    from fluids_bench.data.minari_export import export_minari

    first = collect("DAG-v0", 2, progress=False)
    other = collect("DAG-v0", 3, seed=9, progress=False)
    create, raced = minari.create_dataset_from_buffers, []
    meta = {"algorithm_name": "test", "description": "test"}

    def another_run_finishes_first(*args, **kwargs):
        out = create(*args, **kwargs)
        if not raced:  # once: the other run's own export goes through here too
            raced.append(True)
            with minari_export._datasets_root(datasets_root):
                export_minari("test/late-v0", other, env_id="DAG-v0", **meta)
        return out

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(minari, "create_dataset_from_buffers", another_run_finishes_first)
        with pytest.raises(FileExistsError, match="appeared during the export"):
            export_minari("test/late-v0", first, env_id="DAG-v0", **meta)
    assert minari.load_dataset("test/late-v0").total_episodes == 3  # the other run's, kept
