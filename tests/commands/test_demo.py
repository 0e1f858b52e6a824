"""``fluids-bench demo --env ID``: every registered id (Gymnasium and PettingZoo) has a demo."""

from __future__ import annotations

import os

import imageio.v2 as imageio
import pytest

from fluids_bench.cli import main
from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS

EVERY_ID = sorted(ENV_SPECS) + sorted(PARALLEL_ENV_SPECS)


@pytest.mark.parametrize("env_id", EVERY_ID)
def test_every_registered_id_has_a_demo_in_its_own_folder(env_id, tmp_path, monkeypatch, capsys):
    # short (--steps 5) and without video, from a clean working directory: the demo writes
    # into fluids_demo/<ID>/ and nothing else (no MUJOCO_LOG.TXT from MuJoCo's warnings)
    monkeypatch.chdir(tmp_path)
    argv = ["demo", "--env", env_id, "--steps", "5", "--no-video", "--no-progress"]
    assert main(argv) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert out.startswith(f"{env_id} demo")
    assert "steps: 5" in out or env_id == "DAG-v0"  # the DAG ends after 3 decisions
    assert os.listdir(tmp_path) == ["fluids_demo"]
    written = sorted(os.listdir(tmp_path / "fluids_demo" / env_id))
    assert written == (["episode.png", "episode.txt"] if env_id == "DAG-v0" else ["episode.png"])


def test_gridworld_demo_records_its_supervisor(tmp_path, capsys):
    out = tmp_path / "grid"
    argv = ["demo", "--env", "GridWorld-v0", "--seed", "2", "--out", str(out), "--frame-every", "1"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert text.startswith("GridWorld-v0 demo: seed 2")
    assert "return:" in text and "steps: 30" in text and "steps/s" in text  # registered limit
    frames = imageio.mimread(out / "episode.mp4")
    assert len(frames) == 31  # the reset frame and one per step
    assert imageio.imread(out / "episode.png").ndim == 3


def test_a_frame_stride_keeps_every_kth_step_and_the_last(tmp_path, capsys):
    out = tmp_path / "grid"
    argv = ["demo", "--env", "GridWorld-v0", "--out", str(out), "--frame-every", "7"]
    assert main(argv) == 0
    assert len(imageio.mimread(out / "episode.mp4")) == 6  # steps 0, 7, 14, 21, 28 and 30
    assert "(6 frames, every 7 steps and the last)" in capsys.readouterr().out


def test_no_video_draws_one_frame(tmp_path, monkeypatch):
    from fluids_bench.tasks.gridworld.env import GridWorldEnv

    render, drawn = GridWorldEnv.render, []

    def counted(self):
        drawn.append(1)
        return render(self)

    monkeypatch.setattr(GridWorldEnv, "render", counted)
    argv = ["demo", "--env", "GridWorld-v0", "--no-video", "--out", str(tmp_path / "g")]
    assert main(argv) == 0
    assert len(drawn) == 1  # the last frame, for the PNG; was one per step


def test_fluids_demo_keeps_its_summary(tmp_path, capsys):
    out = tmp_path / "fluids"
    argv = ["demo", "--env", "FLUIDS-v0", "--steps", "5", "--no-video", "--out", str(out)]
    assert main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("FLUIDS-v0 demo: layout four_way, seed 0, ego route ")
    assert lines[1].startswith("  success: False   steps: 5   collisions: 0")
    assert sorted(p.name for p in out.iterdir()) == ["episode.png"]


def test_multi_agent_demo_runs_every_agent_through_pettingzoo(tmp_path, capsys):
    out = tmp_path / "multi"
    argv = ["demo", "--env", "FLUIDS-MultiAgent-v1", "--steps", "8", "--out", str(out)]
    assert main([*argv, "--no-progress"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == (
        "FLUIDS-MultiAgent-v1 demo (PettingZoo ParallelEnv): seed 0, 4 agents, each following "
        "its supervisor label"
    )
    assert "steps: 8" in lines[1]
    assert len(imageio.mimread(out / "episode.mp4")) == 9


def test_dag_demo_is_a_text_trace_and_a_picture(tmp_path, capsys):
    out = tmp_path / "dag"
    assert main(["demo", "--env", "DAG-v0", "--out", str(out), "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "step 1: the supervisor chose L, reward 2.000" in text
    assert (out / "episode.txt").read_text().splitlines()[0] == "reset: observation [0., 0.]"
    assert len(imageio.mimread(out / "episode.mp4")) == 4  # the root and three decisions
    assert (out / "episode.png").stat().st_size > 0


def test_driving_track_summary_explains_the_crashes(tmp_path, capsys):
    argv = ["demo", "--env", "DrivingTrack-v0", "--no-video", "--out", str(tmp_path / "t")]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "success: False   return: -3.000" in text  # seed 0: three crashes in two laps
    assert "crashes: 3 in 2.02 laps; a crash puts the car back on the road" in text


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["--env", "Nope-v0"],
            f"a Gymnasium id ({', '.join(sorted(ENV_SPECS))}) or a PettingZoo id "
            f"({', '.join(sorted(PARALLEL_ENV_SPECS))})",
        ),
        (["--env", "CartPole-v1"], "has no supervisor"),
        (["--env", "GridWorld-v0", "--layout", "roundabout"], "FLUIDS ids only"),
        (["--steps", "0"], "--steps is 0"),
        (["--frame-every", "0"], "--frame-every is 0; allowed: an integer >= 1"),
    ],
)
def test_bad_ids_and_options_are_clear_errors(argv, message, tmp_path, capsys):
    assert main(["demo", *argv, "--out", str(tmp_path / "x")]) == 2
    assert message in capsys.readouterr().err


def test_demo_defaults_to_the_benchmark_id(tmp_path, capsys):
    out = tmp_path / "default"
    assert main(["demo", "--steps", "5", "--no-video", "--out", str(out)]) == 0
    assert capsys.readouterr().out.splitlines()[0].startswith("FLUIDS-v4 demo: layout four_way")
