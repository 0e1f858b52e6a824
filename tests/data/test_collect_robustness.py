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


def _descendants(pid: int) -> list[int]:
    parents: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            parents.setdefault(int(stat.rsplit(")", 1)[1].split()[1]), []).append(int(entry))
    out, todo = [], [pid]
    while todo:
        kids = parents.get(todo.pop(), [])
        out += kids
        todo += kids
    return out


def _running(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _wait_for_workers(process: subprocess.Popen, count: int, timeout: float = 90) -> list[int]:
    """The process's descendants once ``count`` exist (resource tracker, fork server, workers)."""
    deadline = time.monotonic() + timeout
    while len(found := _descendants(process.pid)) < count:
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
        while any(map(_running, family)) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not [pid for pid in family if _running(pid)], "orphaned worker processes"
    finally:
        for pid in family:
            if _running(pid):
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
        alive = [pid for pid in [process.pid, *family] if _running(pid)]
        os.killpg(process.pid, signal.SIGKILL)
        _, err = process.communicate()
        pytest.fail(f"not ended 60 s after Ctrl-C; processes alive: {alive}; stderr:\n{err}")
    assert process.returncode == 130, err
    assert err.strip().splitlines() == ["fluids-bench collect: interrupted"], err
    deadline = time.monotonic() + 10
    while any(map(_running, family)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [pid for pid in family if _running(pid)]


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
