"""evaluate() with a user learner's train run: its saved learner, and the observation it was
trained with (FLUIDS from bird's-eye images on the same episodes as the references)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from train_extra import require_torch

from fluids_bench.benchmark.evaluator import evaluate
from fluids_bench.benchmark.suite import SUITE, Suite
from fluids_bench.cli import main

BIRDSEYE = {"obs_type": "birdseye", "birdseye_size": 64}


def _rows(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


@pytest.mark.train_extra
def test_a_learner_run_is_evaluated_from_its_saved_learner(tmp_path: Path) -> None:
    require_torch()
    from fluids_bench.algos.learners import load_learner

    assert main(
        ["train", "--env", "GridWorld-v0", "--algo", "bc", "--iterations", "2",
         "--policy", "fluids_bench.algos.learners:MLPLearner", "--policy-param", "hidden=[16]",
         "--policy-param", "epochs=5", "--policy-param", "threads=1",
         "--eval-episodes", "2", "--out", str(tmp_path / "train"), "--no-progress"]
    ) == 0  # fmt: skip
    result = tmp_path / "train" / "bc_GridWorld-v0_seed0.json"
    checkpoint = tmp_path / "train" / "bc_GridWorld-v0_seed0.learner.npz"
    suite = SUITE.select(episodes=2, tasks=["gridworld"])
    card = evaluate(str(result), suite, tmp_path / "eval", progress=False, plots=False)
    policy = card["policy"]
    # the card records the path relative to the working directory (no machine's folders)
    assert policy["kind"] == "learner"
    assert Path(policy["learner_checkpoint"]).resolve() == checkpoint.resolve()
    assert policy["learner"].startswith("fluids_bench.algos.learners:MLPLearner")
    assert (
        policy["labels_used"] == json.loads(result.read_text())["records"][-1]["labels_requested"]
    )
    assert "gridworld" in card["label_efficiency"]
    # the same episodes as the checkpoint itself, evaluated directly
    direct = evaluate(
        load_learner(checkpoint), suite, tmp_path / "eval", name="direct", progress=False,
        plots=False,
    )  # fmt: skip
    keys = ("set", "seed", "return", "length")
    ours = _rows(tmp_path / "eval/episodes/bc_GridWorld-v0_seed0.jsonl")
    theirs = _rows(tmp_path / "eval/episodes/direct.jsonl")
    assert [[r[k] for k in keys] for r in ours] == [[r[k] for k in keys] for r in theirs]
    assert len(ours) == 4
    assert (
        direct["tasks"]["gridworld"]["sets"]["test"]["return"]
        == (card["tasks"]["gridworld"]["sets"]["test"]["return"])
    )
    checkpoint.unlink()
    with pytest.raises(ValueError, match=r"learner.npz, which is missing"):
        evaluate(str(result), suite, tmp_path / "eval2", progress=False, plots=False)


def test_observation_kwargs_leave_the_fluids_episode_unchanged() -> None:
    """What lets the references' episodes stand for a bird's-eye policy's: the same seed and
    actions give the same rewards whatever the observation."""
    envs = [gym.make("FLUIDS-v4"), gym.make("FLUIDS-v4", **BIRDSEYE)]
    infos = [env.reset(seed=3_000_000_001)[1] for env in envs]
    for _ in range(60):
        action = infos[0]["supervisor_action"]
        steps = [env.step(action) for env in envs]
        assert steps[0][1] == steps[1][1]  # reward
        np.testing.assert_array_equal(
            steps[0][4]["supervisor_action"], steps[1][4]["supervisor_action"]
        )
        infos = [s[4] for s in steps]
        if steps[0][2] or steps[0][3]:
            break
    assert envs[1].observation_space.shape == (64, 64, 3)


def _birdseye_run(tmp_path: Path, env_kwargs: dict) -> Path:
    """A finished train result of a CNN on FLUIDS-v4 with `env_kwargs`, written by hand (no
    records to replay), with its saved learner next to it."""
    require_torch()
    from fluids_bench.algos.learners import CNNLearner

    env = gym.make("FLUIDS-v4", **BIRDSEYE)
    learner = CNNLearner(hidden=(8,), epochs=1, seed=0, threads=1)
    learner.set_spaces(env.observation_space, env.action_space)
    rng = np.random.default_rng(0)
    learner.fit(
        rng.integers(0, 256, (24, 64, 64, 3), dtype=np.uint8),
        rng.uniform(-1, 1, (24, 10)).astype(np.float32),
    )
    path = tmp_path / "dagger_FLUIDS-v4_seed0.json"
    learner.save(path.with_name(path.stem + ".learner.npz"))
    config = {"env_id": "FLUIDS-v4", "env_kwargs": env_kwargs, "seed": 0, "eval_episodes": 1,
              "policy": {"learner": "fluids_bench.algos.learners:CNNLearner"}}  # fmt: skip
    path.write_text(json.dumps({"algo": "dagger", "config": config, "records": [],
                                "complete": True}))  # fmt: skip
    return path


@pytest.mark.train_extra
def test_a_birdseye_run_is_evaluated_with_its_observation(tmp_path: Path) -> None:
    result = _birdseye_run(tmp_path, BIRDSEYE)
    suite = Suite((replace(SUITE.task("fluids"), ood=()),), episodes=1)
    card = evaluate(str(result), suite, tmp_path / "eval", name="cnn", progress=False, plots=False)
    fluids = card["tasks"]["fluids"]
    assert fluids["observation_kwargs"] == BIRDSEYE
    assert fluids["sets"]["test"]["kwargs"] == {}
    assert fluids["sets"]["test"]["policy_kwargs"] == BIRDSEYE
    assert card["policy"]["env_kwargs"] == BIRDSEYE
    (own,) = _rows(tmp_path / "eval/episodes/cnn.jsonl")
    assert json.loads(own["env_kwargs"]) == BIRDSEYE
    for reference in ("random", "supervisor"):
        (row,) = _rows(tmp_path / f"eval/episodes/{reference}.jsonl")
        assert row["env_kwargs"] == "{}" and row["seed"] == own["seed"]


@pytest.mark.train_extra
@pytest.mark.parametrize("kwargs", [{**BIRDSEYE, "num_cars": 6}, {**BIRDSEYE, "pixel_noise": 4.0}])
def test_a_run_with_other_than_observation_kwargs_is_refused(tmp_path: Path, kwargs) -> None:
    result = _birdseye_run(tmp_path, kwargs)
    with pytest.raises(ValueError, match="only the observation kwargs"):
        evaluate(str(result), SUITE.select(episodes=1, tasks=["fluids"]), tmp_path / "eval",
                 progress=False, plots=False)  # fmt: skip
