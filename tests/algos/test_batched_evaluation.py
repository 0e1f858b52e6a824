"""The harness's FLUIDS evaluations and rollouts stepped together on the vector env are the
one-by-one rollouts: the same summaries (the supervisor, a learner) and the same trajectories
(the supervisor, a noisy supervisor, a mixture with a learner), with episodes of different
lengths, a `max_steps` cut, refilled worlds and the last episodes in smaller envs (B = 3, 5
seeds)."""

from __future__ import annotations

import numpy as np
import pytest
from small_fluids import SMALL_FLUIDS

from fluids_bench.algos import harness as harness_module
from fluids_bench.algos.actors import SUPERVISOR, LearnerActor, MixtureActor
from fluids_bench.algos.evaluation import evaluate_trajectories
from fluids_bench.algos.harness import Harness, RunConfig
from fluids_bench.algos.noise import isotropic_actor
from fluids_bench.algos.rollout import rollout


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


def _same_info(a: dict, b: dict) -> bool:
    """Equal values (the batch gives numpy scalars where the scalar env has Python ones)."""
    if a.keys() != b.keys():
        return False
    for key, value in a.items():
        other = b[key]
        if isinstance(value, dict):
            if not _same_info(value, other):
                return False
        elif isinstance(value, np.ndarray | np.generic) or isinstance(other, np.ndarray):
            if not np.array_equal(value, other):
                return False
        elif value != other:
            return False
    return True


@pytest.mark.parametrize("max_steps", [None, 25])
def test_batched_rollouts_are_the_scalar_rollouts(max_steps, monkeypatch):
    monkeypatch.setattr(harness_module, "EVAL_BATCH", 3)
    config = RunConfig(**SMALL_FLUIDS, eval_episodes=2, seed=4, max_steps=max_steps)
    with Harness("bc", config) as harness:
        harness.aggregate(harness.collect(SUPERVISOR))
        learner = LearnerActor(harness.fit())
        noisy = isotropic_actor(harness.action_space, 0.3, 0.0)
        seeds = [11, 12, 13, 14, 15]
        for actor in (SUPERVISOR, noisy, MixtureActor(0.5, learner)):
            assert harness._batched(actor)
            batched = harness._rollouts(actor, seeds)
            for got, seed in zip(batched, seeds, strict=True):
                want = rollout(harness.env, actor, seed, max_steps)
                for name in ("observations", "actions", "labels", "rewards"):
                    a, b = getattr(got, name), getattr(want, name)
                    assert a.dtype == b.dtype and np.array_equal(a, b), name
                assert (got.terminated, got.truncated, got.seed) == (
                    want.terminated, want.truncated, want.seed,
                )  # fmt: skip
                assert len(got.infos) == len(want.infos)
                assert all(_same_info(a, b) for a, b in zip(got.infos, want.infos, strict=True))
