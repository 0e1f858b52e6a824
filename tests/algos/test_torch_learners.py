"""The torch learners: determinism, warm start, early stopping, checkpoints, every algorithm."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from gymnasium import spaces
from point_mass_env import ENV_ID as POINT_MASS
from train_extra import TORCH_REASON

import fluids_bench  # noqa: F401
from fluids_bench.algos.learners import Learner, LearnerPolicy
from fluids_bench.algos.registry import ALGORITHMS, run_algorithm

pytestmark = pytest.mark.train_extra  # .ci/run's second phase runs it, with torch
torch = pytest.importorskip("torch", reason=TORCH_REASON)

from fluids_bench.algos.learners.torch_nets import (  # noqa: E402
    CNNLearner,
    MLPLearner,
    load_learner,
)

QUICK = {"hidden": (16,), "epochs": 5, "batch_size": 16, "threads": 1}


def _vector_data(n: int = 120, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, 6))
    return X, (X[:, 0] > 0).astype(np.int64), np.tanh(X[:, :2])


def _images(n: int = 40, size: int = 40) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(1)
    images = rng.integers(0, 256, size=(n, size, size, 3), dtype=np.uint8)
    labels = (images[:, :, : size // 2].mean(axis=(1, 2, 3)) > 127.5).astype(np.int64)
    return images, labels


def _weights(learner: MLPLearner | CNNLearner) -> list[bytes]:
    return [t.detach().numpy().tobytes() for t in learner._model.state_dict().values()]  # noqa: SLF001


def test_they_are_learners() -> None:
    assert isinstance(MLPLearner(), Learner)
    assert isinstance(CNNLearner(), Learner)


@pytest.mark.parametrize("make", [MLPLearner, CNNLearner])
def test_same_seed_same_weights_bit_for_bit_and_another_seed_differs(make) -> None:
    X, y = _images() if make is CNNLearner else _vector_data()[:2]
    a = make(seed=3, **QUICK).fit(X, y)
    b = make(seed=3, **QUICK).fit(X, y)
    assert _weights(a) == _weights(b)
    assert _weights(make(seed=4, **QUICK).fit(X, y)) != _weights(a)
    # refits continue bit-identically too (warm start)
    assert _weights(a.fit(X, y)) == _weights(b.fit(X, y))


def test_regression_on_box_labels_learns_and_clips_to_the_bounds() -> None:
    X, _, U = _vector_data(200)
    learner = MLPLearner(hidden=(32,), epochs=60, learning_rate=1e-2, seed=0, threads=1)
    learner.set_spaces(spaces.Box(-10, 10, (6,)), spaces.Box(-0.5, 0.5, (2,), np.float32))
    out = learner.fit(X, U).predict(X)
    assert out.shape == (200, 2) and out.max() <= 0.5 and out.min() >= -0.5
    assert np.mean((out - np.clip(U, -0.5, 0.5)) ** 2) < 0.01


def test_classification_learns_a_separable_rule() -> None:
    X, y, _ = _vector_data(200)
    learner = MLPLearner(hidden=(32,), epochs=40, learning_rate=1e-2, seed=0, threads=1)
    learner.fit(X, y)
    assert np.mean(learner.predict(X) == y) > 0.95
    assert learner.predict(X).dtype == np.int64


def test_warm_start_continues_from_the_previous_weights() -> None:
    X, y, _ = _vector_data()
    warm = MLPLearner(seed=0, **QUICK).fit(X, y)
    before = _weights(warm)
    warm.fit(X, y)
    assert _weights(warm) != before
    # a cold refit starts from the seeded initial weights every time
    again = MLPLearner(seed=0, warm_start=False, **QUICK).fit(X, y).fit(X, y)
    fresh = MLPLearner(seed=0, warm_start=False, **QUICK)
    fresh.fits = 1  # the same shuffling stream as the second fit
    assert _weights(fresh.fit(X, y)) == _weights(again)


def test_early_stopping_keeps_the_best_validation_epoch() -> None:
    rng = np.random.default_rng(0)
    X, y = rng.normal(size=(60, 4)), rng.integers(0, 2, size=60)  # noise: overfits at once
    seen: list[dict] = []
    learner = MLPLearner(
        hidden=(64,), epochs=300, patience=3, validation_fraction=0.3, threads=1,
        progress=seen.append,
    ).fit(X, y)  # fmt: skip
    summary = learner.history[-1]
    assert summary["epochs_run"] < 300 and summary["validation_pairs"] == 18
    assert summary["epochs_run"] - summary["best_epoch"] == 3
    assert len(seen) == summary["epochs_run"] and seen[0]["val_loss"] is not None
    best = min(e["val_loss"] for e in seen)
    assert summary["best_val_loss"] == best


def test_progress_true_prints_a_line_per_epoch(capsys: pytest.CaptureFixture[str]) -> None:
    X, y, _ = _vector_data(30)
    MLPLearner(progress=True, **QUICK).fit(X, y)
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 5 and lines[0].startswith("mlp fit 1: epoch 1/5, train loss")


@pytest.mark.parametrize("make", [MLPLearner, CNNLearner])
def test_a_checkpoint_reloads_to_the_same_predictions_without_pickle(make, tmp_path) -> None:
    X, y = _images() if make is CNNLearner else _vector_data()[:2]
    learner = make(seed=1, **QUICK)
    learner.set_spaces(spaces.Box(0, 255, X.shape[1:], X.dtype), spaces.Discrete(2, start=0))
    learner.fit(X, y)
    path = learner.save(tmp_path / "learner.npz")
    with np.load(path, allow_pickle=False) as archive:  # plain arrays only
        assert "config.json" in archive.files
    again = load_learner(path)
    assert again.predict(X).tobytes() == learner.predict(X).tobytes()
    assert type(again) is make and again.params() == learner.params()
    assert again.history == learner.history and again.history[-1]["epochs_run"] >= 1


def test_load_learner_refuses_what_is_not_a_checkpoint(tmp_path) -> None:
    other = tmp_path / "other.npz"
    np.savez(other, x=np.zeros(3))
    with pytest.raises(ValueError, match="holds no config.json"):
        load_learner(other)
    text = tmp_path / "text.npz"
    text.write_text("hello")
    with pytest.raises(ValueError, match="not a learner checkpoint"):
        load_learner(text)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"epochs": 0}, "field 'epochs' is 0"),
        ({"hidden": "64"}, "field 'hidden'"),
        ({"device": "tpu"}, "field 'device' is 'tpu'"),
        ({"validation_fraction": 1.0}, "field 'validation_fraction'"),
    ],
)
def test_bad_settings_name_the_field(kwargs, message) -> None:
    with pytest.raises(ValueError, match=message):
        MLPLearner(**kwargs)


def test_unknown_keyword_is_a_type_error() -> None:
    with pytest.raises(TypeError, match="unexpected keyword argument 'layers'"):
        MLPLearner(layers=3)


def test_cnn_refuses_vectors_and_tiny_images() -> None:
    with pytest.raises(ValueError, match="MLPLearner takes vectors"):
        CNNLearner(**QUICK).fit(np.zeros((4, 6)), np.zeros(4, np.int64))
    with pytest.raises(ValueError, match="H, W >= 36"):
        CNNLearner(**QUICK).fit(np.zeros((4, 20, 20, 3), np.uint8), np.zeros(4, np.int64))


@pytest.mark.parametrize("name", sorted(ALGORITHMS))
def test_every_algorithm_trains_the_mlp(name) -> None:
    settings = {"env_id": POINT_MASS, "iterations": 2, "eval_episodes": 2, "samples_per_demo": 15}
    if name == "dart":
        settings["update_at"] = (1, 2)
    learner = MLPLearner(seed=0, **QUICK)
    result = run_algorithm(name, seed=1, policy=learner, **settings)
    assert isinstance(result.policy, LearnerPolicy) and learner.fits >= 1
    assert result.final.normalised_performance is not None
    again = run_algorithm(name, seed=1, policy=MLPLearner(seed=0, **QUICK), **settings)
    assert again.to_dict(include_timing=False) == result.to_dict(include_timing=False)


def test_the_package_imports_without_torch_and_the_error_names_the_extra() -> None:
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'torch' or name.startswith('torch.'):\n"
        "            raise ModuleNotFoundError(name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "import fluids_bench.algos.learners as L\n"
        "from fluids_bench.algos import bc\n"
        "try:\n    L.MLPLearner()\nexcept ImportError as e:\n    print(e)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "`torch` extra" in out.stdout and "pip install torch==2.13.0" in out.stdout


def test_worker_processes_roll_out_the_same_network() -> None:
    # the learner travels to the workers pickled (its progress callback stays behind)
    settings = {"env_id": "GridWorld-v0", "iterations": 2, "eval_episodes": 2}
    here = run_algorithm("dagger", seed=3, policy=MLPLearner(seed=0, **QUICK), **settings)
    there = run_algorithm(
        "dagger", seed=3, workers=2, policy=MLPLearner(seed=0, progress=print, **QUICK), **settings
    )
    assert there.to_dict(include_timing=False) == here.to_dict(include_timing=False)


@pytest.mark.parametrize(
    ("env_id", "env_kwargs"),
    [
        ("Singulation-v0", {"obs_type": "pixels"}),
        ("FLUIDS-Sensitivity-v3", {"obs_type": "birdseye", "birdseye_size": 64}),
    ],
)
def test_dagger_trains_the_cnn_on_the_suites_images(env_id: str, env_kwargs: dict) -> None:
    learner = CNNLearner(hidden=(16,), epochs=2, threads=1, seed=0)
    result = run_algorithm(
        "dagger", env_id=env_id, env_kwargs=env_kwargs, policy=learner, iterations=1,
        eval_episodes=1, max_steps=15, samples_per_demo=15,
    )  # fmt: skip
    assert learner.observation_shape == (64, 64, 3) or learner.observation_shape == (96, 96, 3)
    assert learner.fits == 2 and result.final.eval_return is not None
