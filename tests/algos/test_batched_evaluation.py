"""The harness's FLUIDS evaluations stepped together on the vector env summarise exactly as
the one-by-one rollouts do: the supervisor and a learner, episodes of different lengths, a
`max_steps` cut, refilled worlds and the last episodes in smaller envs (B = 3, 5 seeds)."""

from __future__ import annotations

import pytest
from small_fluids import SMALL_FLUIDS

from fluids_bench.algos import harness as harness_module
from fluids_bench.algos.actors import SUPERVISOR, LearnerActor
from fluids_bench.algos.evaluation import evaluate_trajectories
from fluids_bench.algos.harness import Harness, RunConfig


@pytest.mark.parametrize("max_steps", [None, 25])
def test_batched_evaluation_equals_the_rollouts(max_steps, monkeypatch):
    monkeypatch.setattr(harness_module, "EVAL_BATCH", 3)
    config = RunConfig(**SMALL_FLUIDS, eval_episodes=5, seed=3, max_steps=max_steps)
    with Harness("bc", config) as harness:
        assert harness._batched(SUPERVISOR)
        harness.aggregate(harness.collect(SUPERVISOR))
        learner = LearnerActor(harness.fit())
        for actor in (SUPERVISOR, learner):
            rollouts = harness._rollouts(actor, harness.eval_seeds)
            expected = evaluate_trajectories(rollouts, harness._reports_success)
            assert harness._evaluate_batched(actor) == expected
        assert expected.collisions is not None
        if max_steps is None:  # episodes that end at different steps, with success reported
            assert len({len(t) for t in rollouts}) > 1 and expected.success_rate is not None


def test_one_by_one_without_the_batch(monkeypatch):
    monkeypatch.setattr(harness_module, "EVAL_BATCH", 1)
    config = RunConfig(**SMALL_FLUIDS, eval_episodes=2, seed=3, max_steps=10)
    with Harness("bc", config) as harness:
        assert not harness._batched(SUPERVISOR)
