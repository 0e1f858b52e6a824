"""``fluids-bench demo --env ID``: any registered id with a supervisor and rgb_array frames."""

from __future__ import annotations

import imageio.v2 as imageio
import pytest

from fluids_bench.cli import main
from fluids_bench.registration import ENV_SPECS


def test_gridworld_demo_records_its_supervisor(tmp_path, capsys):
    out = tmp_path / "grid"
    assert main(["demo", "--env", "GridWorld-v0", "--seed", "2", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("GridWorld-v0 demo: seed 2")
    assert "return:" in text and "steps: 30" in text and "steps/s" in text  # registered limit
    frames = imageio.mimread(out / "episode.mp4")
    assert len(frames) == 31  # the reset frame and one per step
    assert imageio.imread(out / "episode.png").ndim == 3


def test_fluids_demo_keeps_its_summary(tmp_path, capsys):
    out = tmp_path / "fluids"
    argv = ["demo", "--env", "FLUIDS-v0", "--steps", "5", "--no-video", "--out", str(out)]
    assert main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("FLUIDS-v0 demo: layout four_way, seed 0, ego route ")
    assert lines[1].startswith("  success: False   steps: 5   collisions: 0")
    assert sorted(p.name for p in out.iterdir()) == ["episode.png"]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--env", "Nope-v0"], "registered ids: " + ", ".join(sorted(ENV_SPECS))),
        (["--env", "DAG-v0"], "does not render rgb_array frames"),
        (["--env", "CartPole-v1"], "has no supervisor"),
        (["--env", "GridWorld-v0", "--layout", "roundabout"], "FLUIDS ids only"),
        (["--steps", "0"], "--steps is 0"),
    ],
)
def test_bad_ids_and_options_are_clear_errors(argv, message, tmp_path, capsys):
    assert main(["demo", *argv, "--out", str(tmp_path / "x")]) == 2
    assert message in capsys.readouterr().err
