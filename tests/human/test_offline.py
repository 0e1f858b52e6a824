"""BC on a teleop dataset and DAgger with retroactive (simulated) labels, end to end."""

from __future__ import annotations

import minari

from fluids_bench.algos.policies import PolicySpec
from fluids_bench.cli import main
from fluids_bench.human.offline import retroactive_dagger
from fluids_bench.human.simulated import SimulatedHuman


def test_retroactive_dagger_runs_end_to_end(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    argv = ["teleop", "--env", "GridWorld-v0", "--dataset", "hd/teleop-v0", "--episodes", "1"]
    assert main([*argv, "--simulated-human", "delay=1"]) == 0
    records = retroactive_dagger(
        "GridWorld-v0",
        "hd/teleop-v0",
        namespace="hd",
        iterations=2,
        rollouts=1,
        labeller=SimulatedHuman(delay=0, noise_std=0.0, epsilon=0.0),
        policy=PolicySpec("tree"),
        eval_episodes=2,
    )
    assert [r.iteration for r in records] == [0, 1, 2]
    assert [r.pairs for r in records] == [30, 60, 90]
    assert records[-1].datasets == ("hd/teleop-v0", "hd/learner-iter1-v1", "hd/learner-iter2-v1")
    # a noise-free labeller's retroactive labels are the supervisor's labels
    labelled = minari.load_dataset("hd/learner-iter1-v1")[0]
    assert labelled.actions.tolist() == labelled.infos["original_action"][1:].tolist()


def test_simulated_human_settings_are_checked():
    import pytest

    assert SimulatedHuman.parse("") == SimulatedHuman()
    with pytest.raises(ValueError, match="allowed: delay=INT"):
        SimulatedHuman.parse("lag=3")
    with pytest.raises(ValueError, match="delay"):
        SimulatedHuman.parse("delay=-1")
