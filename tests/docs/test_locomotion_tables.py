"""The locomotion renderers judge the noise targets from the rows, not from prose."""

from __future__ import annotations

from pathlib import Path

from script_module import load_script

TABLES = Path(__file__).parents[2] / "docs" / "_gen" / "tables"


def _load(name: str):
    return load_script(TABLES / f"{name}.py")


TARGETS = [  # the quality script's: no falls at 0.05, falls allowed (and shown) at 0.1
    {"noise_std": 0.05, "min_share_of_clean": 0.9, "no_falls": True},
    {"noise_std": 0.1, "min_share_of_clean": 0.8, "no_falls": False},
]


def _row(env_id, noise, mean, falls=0, flipped=0.0):
    return {
        "env_id": env_id,
        "noise_std": noise,
        "mean_return": mean,
        "falls": falls,
        "episodes": 10,
        "flipped_share": flipped,
    }


def _verdicts(rows):
    data = {
        "rows": rows,
        "noise_targets": TARGETS,
        "episodes": 10,
        "steps": 1000,
        "seeds": "0-9",
        "noise": "n",
    }
    table = _load("locomotion_supervisor_quality").render(data, part="tolerance")
    return {
        line.split("`")[1]: line.rsplit("|", 2)[1].strip()
        for line in table.splitlines()
        if "`" in line
    }


def test_a_teacher_meets_the_targets_only_with_enough_return_and_no_fall():
    rows = [
        _row("Hopper-IL-v0", 0.0, 3000),
        _row("Hopper-IL-v0", 0.05, 2900),
        _row("Hopper-IL-v0", 0.1, 2500, falls=2),  # 83 %; falls at 0.1 are not a target
        _row("Walker2d-IL-v0", 0.0, 4000),
        _row("Walker2d-IL-v0", 0.05, 3900, falls=1),  # enough return, but one fall
        _row("Walker2d-IL-v0", 0.1, 3900),
        _row("Humanoid-IL-v0", 0.0, 7000),
        _row("Humanoid-IL-v0", 0.05, 6000),  # 86 % < 90 %
        _row("Humanoid-IL-v0", 0.1, 6000),
        _row("HalfCheetah-IL-v0", 0.0, 5000),
        _row("HalfCheetah-IL-v0", 0.05, 5000, flipped=0.001),  # on its back: its fall
        _row("HalfCheetah-IL-v0", 0.1, 4900),
    ]
    verdicts = _verdicts(rows)
    assert verdicts == {
        "Hopper-IL-v0": "yes",
        "Walker2d-IL-v0": "**no**",
        "HalfCheetah-IL-v0": "**no**",
        "Humanoid-IL-v0": "**no**",
    }


def test_a_noise_level_not_measured_is_not_met():
    rows = [_row("Hopper-IL-v0", 0.0, 3000), _row("Hopper-IL-v0", 0.05, 3000)]
    assert _verdicts(rows) == {"Hopper-IL-v0": "**no**"}
