"""``fluids-bench train``: outputs, atomic writes and clear errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fluids_bench import cli


@pytest.fixture(autouse=True)
def only_train(monkeypatch: pytest.MonkeyPatch) -> None:
    # test this subcommand through the real dispatcher, independent of the others' modules
    monkeypatch.setattr(cli, "COMMAND_MODULES", ("fluids_bench.commands.train",))


def train(*args: str) -> int:
    return cli.main(["train", "--no-progress", *args])


def test_train_writes_json_and_png(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = train(
        "--env", "GridWorld-v0", "--algo", "dagger_b", "--policy", "tree",
        "--policy-param", "max_depth=100", "--env-kwarg", "world_seed=2",
        "--iterations", "4", "--eval-episodes", "2", "--retrain-at", "1", "3",
        "--eval-at", "0", "2", "--seed", "3", "--out", str(tmp_path),
    )  # fmt: skip
    assert code == 0
    stem = tmp_path / "dagger_b_GridWorld-v0_seed3"
    payload = json.loads(stem.with_suffix(".json").read_text())
    assert payload["algo"] == "dagger_b"
    assert payload["config"]["retrain_at"] == [1, 3]
    assert payload["config"]["env_kwargs"] == {"world_seed": 2}
    assert payload["config"]["policy"] == {"name": "tree", "params": {"max_depth": 100}}
    assert len(payload["records"]) == 5
    assert [r["eval_return"] is not None for r in payload["records"]] == [
        True,
        False,
        True,
        False,
        True,
    ]
    assert stem.with_suffix(".png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.glob(".*.tmp"))  # no temporary files left behind
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--env", "GridWorld-v0", "--algo", "dagr"], "unknown algorithm 'dagr'; allowed: ['bc'"),
        (["--env", "Grid-v9", "--algo", "bc"], "--env is 'Grid-v9', not a registered id"),
        (
            ["--env", "DAG-v0", "--algo", "bc", "--beta", "0.5"],
            "applies to: ['dagger', 'dagger_b']",
        ),
        (["--env", "DAG-v0", "--algo", "shiv", "--selector", "x"], "--selector is 'x'"),
        (["--env", "DAG-v0", "--algo", "bc", "--policy", "forest"], "field 'name' is 'forest'"),
    ],
)
def test_bad_names_and_options_give_clear_errors(
    args: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert train(*args, "--out", str(tmp_path)) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_samples_per_demo_all_and_json_env_kwargs(tmp_path: Path) -> None:
    code = train(
        "--env", "DAG-v0", "--algo", "dart", "--env-kwarg", "mu=0.5", "--samples-per-demo",
        "all", "--heldout-fraction", "0.4", "--update-at", "1", "--iterations", "2",
        "--eval-episodes", "1", "--out", str(tmp_path),
    )  # fmt: skip
    assert code == 0
    config = json.loads((tmp_path / "dart_DAG-v0_seed0.json").read_text())["config"]
    assert config["samples_per_demo"] is None and config["env_kwargs"] == {"mu": 0.5}


def test_train_accepts_the_protocol_knobs_and_reports_both_label_counts(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from point_mass_env import ENV_ID

    code = train(
        "--env", ENV_ID, "--algo", "dart", "--iterations", "4", "--eval-episodes", "1",
        "--samples-per-demo", "10", "--initial-demos", "2", "--update-every", "2",
        "--alpha-relative", "3", "--alpha-reference", "first", "--x-axis", "demonstrations",
        "--out", str(tmp_path),
    )  # fmt: skip
    assert code == 0
    payload = json.loads((tmp_path / f"dart_{ENV_ID}_seed0.json").read_text())
    assert payload["config"]["update_every"] == 2 and payload["config"]["alpha_relative"] == 3.0
    final = payload["records"][-1]
    assert final["training_labels"] == final["estimation_labels"] == 60
    out = capsys.readouterr().out
    assert (
        "60 training labels (+60 for noise estimation)" in out
        and "s collecting, labelling and fitting in all (evaluation" in out
    )


def test_summary_numbers_have_a_sensible_precision(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = train(
        "--env", "DAG-v0", "--algo", "bc", "--iterations", "2", "--eval-episodes", "3",
        "--out", str(tmp_path),
    )  # fmt: skip
    assert code == 0
    out = capsys.readouterr().out
    performance = out.split("normalised performance ")[1].split(",")[0]
    assert performance == "n/a" or len(performance.split(".")[1]) == 3, out
    payload = json.loads((tmp_path / "bc_DAG-v0_seed0.json").read_text())
    assert payload["complete"] is True


def test_interrupted_train_keeps_the_finished_iterations(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from fluids_bench.algos.harness import Harness

    collect, calls = Harness.collect_many, []

    def collect_then_ctrl_c(self, actor, count):
        calls.append(actor)
        if len(calls) == 3:  # Ctrl-C during the third iteration's demonstration
            raise KeyboardInterrupt
        return collect(self, actor, count)

    monkeypatch.setattr(Harness, "collect_many", collect_then_ctrl_c)
    code = train(
        "--env", "GridWorld-v0", "--algo", "dagger", "--iterations", "5",
        "--eval-episodes", "1", "--out", str(tmp_path),
    )  # fmt: skip
    assert code == 130
    path = tmp_path / "dagger_GridWorld-v0_seed0.json"
    payload = json.loads(path.read_text())
    assert payload["complete"] is False
    assert [r["iteration"] for r in payload["records"]] == [0, 1]
    assert payload["config"]["iterations"] == 5
    assert f"interrupted; the 2 finished iterations are in {path}" in capsys.readouterr().err
    assert not list(tmp_path.glob(".*.tmp"))


def test_policy_help_lists_every_family() -> None:
    from fluids_bench.algos.policies import FAMILIES
    from fluids_bench.commands.train import POLICY_FAMILIES

    assert POLICY_FAMILIES == FAMILIES
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices["train"]  # noqa: SLF001
    (policy,) = [a for a in sub._actions if a.dest == "policy"]  # noqa: SLF001
    assert all(name in policy.help for name in FAMILIES)
