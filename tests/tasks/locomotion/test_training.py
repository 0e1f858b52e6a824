"""The ARS training script: seeded, resumable, and its shipped file is what the loader checks."""

from __future__ import annotations

import json

import numpy as np
import pytest
from script_module import load_script

from fluids_bench.tasks.locomotion.policy import MLPPolicy

train = load_script("training/train_locomotion_expert.py")

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


def test_a_stage_from_another_runs_checkpoint_continues_it_with_new_settings(tmp_path):
    """``--init``: the second stage carries the first's parameters, statistics, generator and
    iteration count, so it equals resuming the first run with the new settings; its recipe
    records the stage it started from."""
    first, second, resumed = (tmp_path / d / "w.npz" for d in ("first", "second", "resumed"))
    for path in (first, second, resumed):
        path.parent.mkdir()
    assert train.main([*TINY, "--out", str(first), "--iterations", "2"]) == 0
    ckpt = first.with_name("w.npz.ckpt.npz")
    init = [*TINY, "--out", str(second), "--iterations", "4", "--shift", "0", "--init", str(ckpt)]
    assert train.main(init) == 0
    resumed.with_name("w.npz.ckpt.npz").write_bytes(ckpt.read_bytes())
    assert train.main([*TINY, "--out", str(resumed), "--iterations", "4", "--shift", "0"]) == 0
    a = np.load(second.with_name("w.npz.ckpt.npz"))
    b = np.load(resumed.with_name("w.npz.ckpt.npz"))
    assert np.array_equal(a["theta"], b["theta"]) and np.array_equal(a["s2"], b["s2"])
    meta = json.loads(second.with_name("w.npz.json").read_text())
    assert meta["recipe"]["shift"] == 0.0 and meta["recipe"]["init"]["iteration"] == 2
    assert meta["recipe"]["init"]["recipe"]["shift"] == 1.0
    assert [row["iteration"] for row in meta["history"]] == [3, 4]
    assert train.main(init) == 0  # finished: the stage's own checkpoint wins over --init
    assert (
        json.loads(second.with_name("w.npz.json").read_text())["recipe"]["init"]["iteration"] == 2
    )


def test_init_must_be_a_checkpoint(tmp_path, capsys):
    out = tmp_path / "w.npz"
    with pytest.raises(SystemExit):
        train.main([*TINY, "--out", str(out), "--init", str(tmp_path / "missing.npz")])
    assert "--init is" in capsys.readouterr().err


def test_obs_dims_searches_only_the_weights_on_the_first_entries(tmp_path):
    out = tmp_path / "w.npz"
    assert train.main([*TINY, "--out", str(out), "--iterations", "2", "--obs-dims", "5"]) == 0
    with np.load(out) as z:
        first = z["W0"]
    assert first.shape == (4, 11)
    assert np.all(first[:, 5:] == 0) and np.all(first[:, :5] != 0)
    with pytest.raises(SystemExit):
        train.main([*TINY, "--out", str(tmp_path / "x.npz"), "--obs-dims", "12"])


def test_a_stage_from_a_weight_file_starts_at_its_parameters_and_normaliser(tmp_path):
    """``--init-weights``: with a zero step size the parameters stay the file's, and the
    normaliser (the file's, counted as many states) barely moves after one iteration."""
    first = tmp_path / "first" / "w.npz"
    first.parent.mkdir()
    assert train.main([*TINY, "--out", str(first), "--iterations", "2"]) == 0
    source = MLPPolicy.from_bytes(first.read_bytes())
    second = tmp_path / "second" / "w.npz"
    second.parent.mkdir()
    argv = [*TINY, "--out", str(second), "--iterations", "3", "--step-size", "0"]
    assert train.main([*argv, "--init-weights", str(first), "--init-obs-count", "1e9"]) == 0
    ckpt = np.load(second.with_name("w.npz.ckpt.npz"))
    params = np.concatenate(
        [a.ravel() for w, b in zip(source.weights, source.biases, strict=True) for a in (w, b)]
    )
    assert np.array_equal(ckpt["theta"], params)
    assert np.allclose(ckpt["s1"] / ckpt["n"], source.obs_mean, rtol=1e-6, atol=1e-9)
    meta = json.loads(second.with_name("w.npz.json").read_text())
    record = meta["recipe"]["init"]
    assert record["weights"] == "w.npz" and record["obs_count"] == 1e9
    # the file's own record (written beside it) carries on its run's iteration count
    assert record["iteration"] == 2 and record["recipe"]["n_directions"] == 3
    assert [row["iteration"] for row in meta["history"]] == [3]
    with pytest.raises(SystemExit):  # the file's layers are not this run's
        train.main([*argv, "--hidden", "5", "--init-weights", str(first)])


def test_action_noise_is_seeded_and_changes_the_episode():
    env = train._env("Hopper")
    shapes = train.layer_shapes(11, 3, [])
    theta = np.random.default_rng(0).normal(0, 0.1, sum(o * i + o for o, i in shapes))
    job = ["Hopper", theta, shapes, np.zeros(11), np.ones(11), 7, 0.0, 50]
    clean = train.rollout((*job, 0.0))
    noisy = train.rollout((*job, 0.1))
    assert noisy[1] == train.rollout((*job, 0.1))[1]
    assert noisy[1] != clean[1]
    assert env.action_space.shape == (3,)


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--action-noise", "-0.1"], "--action-noise is"),
        (["--action-noise", "nan"], "--action-noise is"),
        (["--init-obs-count", "1"], "--init-obs-count is"),
    ],
)
def test_bad_noise_settings_are_refused(tmp_path, capsys, extra, message):
    with pytest.raises(SystemExit):
        train.main([*TINY, "--out", str(tmp_path / "w.npz"), *extra])
    assert message in capsys.readouterr().err


def test_paired_seeds_give_a_directions_two_episodes_one_seed(tmp_path):
    # with zero parameter noise a direction's two policies are the same: paired, their episodes
    # are the same too, so no reward difference moves the parameters; unpaired, luck does
    # (no hidden layer: the parameters start at zero)
    argv = [*TINY, "--hidden", "--noise", "0", "--action-noise", "0.1", "--iterations", "1"]
    thetas = {}
    for paired in (False, True):
        out = tmp_path / str(paired) / "w.npz"
        out.parent.mkdir()
        train.main([*argv, "--out", str(out), *(["--paired-seeds"] if paired else [])])
        thetas[paired] = np.load(out.with_name("w.npz.ckpt.npz"))["theta"]
        recipe = json.loads(out.with_name("w.npz.json").read_text())["recipe"]
        assert recipe["paired_seeds"] is paired
    assert np.all(thetas[True] == 0.0) and np.any(thetas[False] != 0.0)
