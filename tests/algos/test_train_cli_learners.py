"""``fluids-bench train --policy module:factory``: a user's learner from the command line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from train_extra import require_torch

from fluids_bench import cli


@pytest.fixture(autouse=True)
def only_train(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cli, "COMMAND_MODULES", ("fluids_bench.commands.train",))


def train(*args: str) -> int:
    return cli.main(["train", "--no-progress", *args])


GRID = ["--env", "GridWorld-v0", "--env-kwarg", "world_seed=2", "--iterations", "2"]


def test_a_factory_trains_and_is_recorded_by_name(tmp_path: Path) -> None:
    code = train(*GRID, "--algo", "dagger", "--policy", "learner_double:make",
                 "--eval-episodes", "2", "--out", str(tmp_path))  # fmt: skip
    assert code == 0
    payload = json.loads((tmp_path / "dagger_GridWorld-v0_seed0.json").read_text())
    assert payload["config"]["policy"] == {"learner": "learner_double:make"}
    assert payload["complete"] is True
    assert not list(tmp_path.glob("*.learner.npz"))  # the double has no save()


@pytest.mark.parametrize(
    ("policy", "message"),
    [
        ("no_such_module_xyz:make", "module 'no_such_module_xyz' does not import"),
        ("learner_double:nothing", "has no attribute 'nothing'"),
        ("learner_double:NOT_A_FACTORY", "is not callable"),
        ("builtins:object", "is not a learner"),
    ],
)
def test_a_bad_factory_is_refused_clearly(
    policy: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert train(*GRID, "--algo", "bc", "--policy", policy, "--out", str(tmp_path)) == 2
    assert message in capsys.readouterr().err


def test_factory_keywords_come_from_policy_param(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = train(*GRID, "--algo", "bc", "--policy", "learner_double:make",
                 "--policy-param", "depth=3", "--out", str(tmp_path))  # fmt: skip
    assert code == 2
    assert "unexpected keyword argument 'depth'" in capsys.readouterr().err


@pytest.mark.train_extra
def test_the_mlp_from_the_command_line_writes_a_loadable_learner(tmp_path: Path) -> None:
    require_torch()
    from fluids_bench.algos.learners import load_learner

    code = train(
        *GRID, "--algo", "dagger", "--policy", "fluids_bench.algos.learners:MLPLearner",
        "--policy-param", "hidden=[16]", "--policy-param", "epochs=5",
        "--policy-param", "threads=1", "--eval-episodes", "2", "--out", str(tmp_path),
    )  # fmt: skip
    assert code == 0
    stem = tmp_path / "dagger_GridWorld-v0_seed0"
    payload = json.loads(stem.with_suffix(".json").read_text())
    assert payload["config"]["policy"] == {
        "learner": 'fluids_bench.algos.learners:MLPLearner {"epochs": 5, "hidden": [16], '
        '"threads": 1}'
    }
    learner = load_learner(tmp_path / "dagger_GridWorld-v0_seed0.learner.npz")
    assert learner.predict(np.zeros((3, *learner.observation_shape))).dtype == np.int64
