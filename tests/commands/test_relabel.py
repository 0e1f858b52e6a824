"""``fluids-bench relabel``: states rebuilt from stored env states, labels from posted events."""

from __future__ import annotations

import functools
import json

import minari
import numpy as np
import pytest

pygame = pytest.importorskip("pygame")

from fluids_bench.cli import main  # noqa: E402
from fluids_bench.human import session  # noqa: E402
from fluids_bench.human.recording import sessions  # noqa: E402


@pytest.fixture(autouse=True)
def datasets_root(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "datasets"))
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("FLUIDS_BENCH_HEADLESS", "1")  # windows without a screen, events posted


def per_state(plan):
    """A relabel script posting ``plan(index)`` once each time a state is shown."""
    posted: list[int] = []

    def script(s):
        if not posted or posted[-1] != s.index or plan.__dict__.get("again"):
            plan.__dict__["again"] = False
            posted.append(s.index)
            for event in plan(s.index, len(posted)):
                pygame.event.post(event)

    return script


def run_relabel(monkeypatch, argv, plan):
    monkeypatch.setattr(
        session, "Relabel", functools.partial(session.Relabel, script=per_state(plan))
    )
    return main(["relabel", *argv])


def key(k):
    return pygame.event.Event(pygame.KEYDOWN, key=k)


def record(argv):
    assert main(["teleop", *argv, "--simulated-human", "delay=2,epsilon=0"]) == 0


def test_gridworld_relabel_changes_labels_and_goes_back(monkeypatch, capsys):
    record(
        ["--env", "GridWorld-v0", "--dataset", "tt/grid-v0", "--episodes", "2", "--max-steps", "5"]
    )
    capsys.readouterr()

    def plan(index, shown):
        if shown == 3:  # at the third state shown: go back once, then carry on
            return [key(pygame.K_BACKSPACE)]
        return [key(pygame.K_SPACE)]  # "stay" everywhere

    assert run_relabel(monkeypatch, ["tt/grid-v0"], plan) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["dataset"] == "tt/grid-v1" and summary["labels"] == 10 == summary["of"]
    assert summary["labels_per_minute"] > 0
    old, new = minari.load_dataset("tt/grid-v0"), minari.load_dataset("tt/grid-v1")
    for a, b in zip(old.iterate_episodes(), new.iterate_episodes(), strict=True):
        assert b.actions.tolist() == [4] * 5
        assert b.infos["original_action"][1:].tolist() == a.actions.tolist()
        assert b.infos["relabelled"][1:].all() and not b.infos["relabelled"][0]
        assert np.all(b.infos["label_time"][1:] >= 0)
        np.testing.assert_array_equal(a.observations, b.observations)
        assert b.infos["executed_action"].tolist() == a.infos["executed_action"].tolist()
    assert [s["kind"] for s in sessions("tt/grid-v1")] == ["teleop", "relabel"]


def test_singulation_relabel_by_clicks_from_sparse_states(monkeypatch, capsys):
    record(
        [
            "--env",
            "Singulation-v0",
            "--dataset",
            "tt/sing-v0",
            "--max-steps",
            "7",
            "--snapshot-every",
            "3",
        ]
    )
    capsys.readouterr()

    def plan(index, shown):  # steps 4, 5, 6 are replayed from the state stored at step 3
        return [pygame.event.Event(pygame.MOUSEBUTTONDOWN, button=1, pos=(100, 380))]

    assert run_relabel(monkeypatch, ["tt/sing-v0", "--out", "tt/sing-v5"], plan) == 0
    new = minari.load_dataset("tt/sing-v5")[0]
    assert (new.actions[:, 0] > 0).all()  # toward the pointer, left of the base: rotate CCW


def test_relabel_a_collect_dataset_replayed_from_its_seeds(capsys):
    assert (
        main(
            [
                "collect",
                "--env",
                "GridWorld-v0",
                "--episodes",
                "2",
                "--dataset",
                "tt/col-v0",
                "--noise",
                "0.3",
                "--no-progress",
            ]
        )
        == 0
    )
    argv = ["relabel", "tt/col-v0", "--simulated-human", "delay=0,epsilon=0", "--every", "2"]
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert summary["labels"] == 30  # every other step of two 30-step episodes
    new = minari.load_dataset("tt/col-v1")
    for ep in new.iterate_episodes():
        # the noise-free simulated human gives the supervisor's labels, as collect recorded
        assert ep.actions.tolist() == ep.infos["original_action"][1:].tolist()
        assert ep.infos["relabelled"][1::2].all() and not ep.infos["relabelled"][2::2].any()


def test_dataset_without_states_or_seeds_is_refused(tmp_path, capsys):
    import gymnasium as gym
    from minari.data_collector import EpisodeBuffer

    import fluids_bench  # noqa: F401

    env = gym.make("GridWorld-v0")
    buffer = EpisodeBuffer(
        id=0,
        observations=np.zeros((3, 2), np.float32),
        actions=np.zeros(2, np.int64),
        rewards=np.zeros(2),
        terminations=np.zeros(2, bool),
        truncations=np.array([False, True]),
    )
    minari.create_dataset_from_buffers(
        "tt/raw-v0",
        [buffer],
        env=env.spec,
        eval_env=env.spec,
        data_format="arrow",
        author="t",
        author_email="t",
        code_permalink="t",
        algorithm_name="t",
        description="t",
    )
    assert main(["relabel", "tt/raw-v0"]) == 2
    assert "stores no env states" in capsys.readouterr().err
    assert main(["relabel", "tt/missing-v0"]) == 2
    assert "cannot load dataset" in capsys.readouterr().err


def test_replay_that_does_not_reproduce_is_refused(capsys):
    assert (
        main(
            [
                "collect",
                "--env",
                "GridWorld-v0",
                "--episodes",
                "1",
                "--dataset",
                "tt/c2-v0",
                "--no-progress",
            ]
        )
        == 0
    )

    from fluids_bench.data.minari_export import dataset_path

    # the same data under other dynamics: its observations do not replay
    data = minari.load_dataset("tt/c2-v0")
    meta = dataset_path("tt/c2-v0") / "data" / "metadata.json"
    text = meta.read_text().replace(
        '\\"kwargs\\": {}', '\\"kwargs\\": {\\"slip_probability\\": 0.9}'
    )
    assert text != meta.read_text()
    meta.write_text(text)
    del data
    assert main(["relabel", "tt/c2-v0", "--simulated-human"]) == 2
    assert "does not reproduce observation" in capsys.readouterr().err


def test_quit_without_labels_writes_nothing(monkeypatch, capsys):
    record(["--env", "GridWorld-v0", "--dataset", "tt/q-v0", "--max-steps", "3"])
    capsys.readouterr()
    assert run_relabel(monkeypatch, ["tt/q-v0"], lambda i, n: [key(pygame.K_ESCAPE)]) == 1
    assert "nothing written" in capsys.readouterr().err
    assert "tt/q-v1" not in minari.list_local_datasets()
