"""An interrupted `fluids-bench collect` keeps its finished episodes (`data/partial.py`): SIGINT
and SIGTERM export them as a dataset marked incomplete, SIGKILL leaves them on disk, and
`--resume` finishes the dataset, identical to an uninterrupted run's. Real subprocesses, real
signals, workers and Ray."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import minari
import numpy as np
import pytest
from minari.data_collector import EpisodeBuffer

from fluids_bench.cli import main
from fluids_bench.commands.collect import INCOMPLETE_FILE
from fluids_bench.core.parallel import descendants, pid_alive
from fluids_bench.data.partial import PARTIAL_DIR, PartialCollection

EPISODES = 40
ARGS = ["--env", "FLUIDS-v0", "--episodes", str(EPISODES), "--max-steps", "8", "--seed", "7",
        "--noise", "0.2", "--no-progress"]  # fmt: skip


@pytest.fixture(autouse=True)
def datasets_root(tmp_path, monkeypatch) -> Path:
    root = tmp_path / "minari"
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")  # a local Ray: no token authentication
    monkeypatch.chdir(tmp_path)
    return root


def _spawn(args: list[str]) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "fluids_bench.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def _episodes(dataset_id: str) -> list[dict]:
    dataset = minari.load_dataset(dataset_id)
    out = []
    for episode in dataset.iterate_episodes():
        out.append(
            {
                "seed": dataset.episode_indices,  # replaced below: the seed from the metadata
                "observations": episode.observations,
                "actions": episode.actions,
                "rewards": episode.rewards,
                "terminations": episode.terminations,
                "truncations": episode.truncations,
                "executed": np.asarray(episode.infos["executed_action"]),
                "provenance": list(episode.infos["provenance"]),
            }
        )
    for row, meta in zip(out, dataset.storage.get_episode_metadata(range(len(out))), strict=True):
        row["seed"] = meta["seed"]
    return out


def _assert_same(left: list[dict], right: list[dict]) -> None:
    assert len(left) == len(right)
    for a, b in zip(left, right, strict=True):
        assert a.keys() == b.keys()
        for key in a:
            if isinstance(a[key], np.ndarray):
                assert a[key].dtype == b[key].dtype and np.array_equal(a[key], b[key]), key
            else:
                assert a[key] == b[key], key


@pytest.mark.parametrize(
    ("sig", "execution"),
    [
        (signal.SIGINT, ["--workers", "2"]),
        (signal.SIGTERM, ["--workers", "2"]),
        (signal.SIGKILL, ["--workers", "2"]),
        (signal.SIGINT, ["--workers", "2", "--backend", "ray"]),
    ],
    ids=["sigint", "sigterm", "sigkill", "sigint-ray"],
)
def test_an_interrupted_collect_keeps_its_episodes_and_resumes(sig, execution, datasets_root):
    partial = PartialCollection(datasets_root, "test/cut-v0")
    process = _spawn(["collect", "--dataset", "test/cut-v0", *ARGS, *execution])
    deadline = time.monotonic() + 240
    while len(partial.done()) < 3:  # a few episodes finished, most not
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline, "no episode finished"
        time.sleep(0.05)
    family = descendants(process.pid)
    if sig == signal.SIGINT:
        os.killpg(process.pid, sig)  # what Ctrl-C in a terminal does
    else:
        os.kill(process.pid, sig)
    _, err = process.communicate(timeout=120)
    kept = partial.done()
    assert 3 <= len(kept) < EPISODES, err
    if sig == signal.SIGKILL:
        assert process.returncode == -signal.SIGKILL
        assert not (datasets_root / "test" / "cut-v0").exists()
    else:
        assert process.returncode == 130, err
        assert f"kept {len(kept)} finished episodes of {EPISODES}" in err, err
        marker = json.loads((datasets_root / "test" / "cut-v0" / INCOMPLETE_FILE).read_text())
        assert marker["episodes"] == kept and marker["of"] == EPISODES
        dataset = minari.load_dataset("test/cut-v0")
        assert dataset.total_episodes == len(kept)
        assert dataset.storage.metadata["description"].startswith("INCOMPLETE")
        # without --resume the incomplete dataset is neither replaced nor silently extended
        assert main(["collect", "--dataset", "test/cut-v0", *ARGS]) == 2
    deadline = time.monotonic() + 15
    while any(map(pid_alive, family)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [pid for pid in family if pid_alive(pid)], "workers outlived the command"

    # another seed is refused by name; the same arguments finish the dataset
    changed = [a if a != "7" else "8" for a in ARGS]
    assert main(["collect", "--dataset", "test/cut-v0", *changed, "--resume"]) == 2
    assert main(["collect", "--dataset", "test/cut-v0", *ARGS, "--resume"]) == 0
    assert not (datasets_root / PARTIAL_DIR).exists()
    assert not (datasets_root / "test" / "cut-v0" / INCOMPLETE_FILE).exists()
    assert main(["collect", "--dataset", "test/whole-v0", *ARGS]) == 0
    _assert_same(_episodes("test/cut-v0"), _episodes("test/whole-v0"))


def test_resume_without_an_interrupted_run_is_refused(capsys):
    assert main(["collect", "--dataset", "test/none-v0", *ARGS, "--resume"]) == 2
    assert "--resume: no interrupted collection of 'test/none-v0'" in capsys.readouterr().err


def test_an_episode_file_round_trips_exactly_without_pickle(datasets_root):
    buffer = EpisodeBuffer(
        id=3,
        seed=12,
        observations={
            "image": np.arange(24, dtype=np.uint8).reshape(2, 3, 4),
            "nested": {"x": np.array([0.1, 0.2], dtype=np.float32)},
        },  # fmt: skip
        actions=np.array([1, 0], dtype=np.int64),
        rewards=np.array([0.5], dtype=np.float64),
        terminations=np.array([True]),
        truncations=np.array([False]),
        infos={"executed_action": [0, 1], "provenance": ["reset", "noise"]},
    )
    partial = PartialCollection(datasets_root, "test/files-v0")
    partial.start({"episodes": 5})
    partial.save(3, buffer)
    assert partial.done() == [3]
    back = partial.load(3)
    assert back.id == 3 and back.seed == 12
    assert back.infos == buffer.infos
    assert type(back.infos["executed_action"][0]) is int
    for name in ("actions", "rewards", "terminations", "truncations"):
        assert np.array_equal(getattr(back, name), getattr(buffer, name))
        assert getattr(back, name).dtype == getattr(buffer, name).dtype
    assert back.observations["image"].dtype == np.uint8
    assert np.array_equal(back.observations["nested"]["x"], buffer.observations["nested"]["x"])
    partial.remove()
    assert not (datasets_root / PARTIAL_DIR).exists()
