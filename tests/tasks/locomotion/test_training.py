"""The ARS training script: seeded, resumable, and its shipped file is what the loader checks."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np

from fluids_bench.tasks.locomotion.policy import MLPPolicy

SCRIPT = Path(__file__).parents[3] / "scripts" / "train_locomotion_expert.py"
spec = importlib.util.spec_from_file_location("train_locomotion_expert", SCRIPT)
train = importlib.util.module_from_spec(spec)
spec.loader.exec_module(train)

TINY = [
    "--env",
    "Hopper",
    "--horizon",
    "40",
    "--eval-every",
    "1",
    "--eval-episodes",
    "1",
    "--n-directions",
    "3",
    "--top",
    "2",
    "--hidden",
    "4",
]


def test_same_seed_same_weights_and_resume_equals_one_run(tmp_path):
    a, b = tmp_path / "a" / "w.npz", tmp_path / "b" / "w.npz"
    a.parent.mkdir()
    b.parent.mkdir()
    assert train.main([*TINY, "--out", str(a), "--iterations", "3"]) == 0
    assert train.main([*TINY, "--out", str(b), "--iterations", "1"]) == 0
    assert train.main([*TINY, "--out", str(b), "--iterations", "3"]) == 0  # resumes at 1
    ca = np.load(a.with_name("w.npz.ckpt.npz"))
    cb = np.load(b.with_name("w.npz.ckpt.npz"))
    assert np.array_equal(ca["theta"], cb["theta"]) and np.array_equal(ca["s1"], cb["s1"])
    assert a.read_bytes() == b.read_bytes()
    meta = json.loads(a.with_name("w.npz.json").read_text())
    assert meta["recipe"]["seed"] == 0 and meta["iterations_done"] == 3
    c = tmp_path / "c" / "w.npz"
    c.parent.mkdir()
    train.main([*TINY, "--out", str(c), "--iterations", "3", "--seed", "1"])
    assert not np.array_equal(np.load(c.with_name("w.npz.ckpt.npz"))["theta"], ca["theta"])


def test_ship_records_the_hash_the_loader_checks(tmp_path):
    out = tmp_path / "w.npz"
    train.main([*TINY, "--out", str(out), "--iterations", "2"])
    folder = tmp_path / "weights"
    assert train.main(["--env", "Hopper", "--out", str(out), "--ship", str(folder)]) == 0
    record = json.loads((folder / "manifest.json").read_text())["Hopper"]
    policy = MLPPolicy.load(folder / record["file"], record["sha256"])
    assert policy.obs_dim == 11 and record["recipe"]["hidden"] == [4]
    assert policy(np.zeros(11)).shape == (3,)
