"""The benchmark's seed splits are disjoint, and no training code path ever uses a test seed."""

from __future__ import annotations

import gymnasium as gym
import pytest

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos import harness as harness_module
from fluids_bench.algos.actors import SUPERVISOR
from fluids_bench.algos.registry import run_algorithm
from fluids_bench.benchmark.suite import SUITE, TASK_NAMES
from fluids_bench.core import splits
from fluids_bench.core.splits import (
    HELD_OUT_START,
    OOD_START,
    TEST_START,
    TRAIN_END,
    VALIDATION_START,
    refuse_test_seeds,
    split_of,
    split_seeds,
)
from fluids_bench.data.collect import collect


def test_blocks_are_ordered_and_within_gymnasium_seeds():
    assert TRAIN_END <= VALIDATION_START < TEST_START < OOD_START < 2**32
    # every task's sets fit in their blocks
    for task in SUITE.tasks:
        assert TEST_START + task.test_episodes <= OOD_START
        assert VALIDATION_START + task.validation_episodes <= TEST_START
        for ood in task.ood:
            assert OOD_START + ood.episodes <= 2**32


@pytest.mark.parametrize("name", TASK_NAMES)
def test_splits_are_disjoint_and_large_enough(name):
    task = SUITE.task(name)
    test, validation = set(task.seeds("test")), set(task.seeds("validation"))
    ood = {s for o in task.ood for s in task.ood_seeds(o.name)}
    assert len(test) == task.test_episodes
    assert task.test_episodes >= (100 if task.family == "locomotion" else 500)
    assert not test & validation and not test & ood and not validation & ood
    assert {split_of(s) for s in test} == {"test"}
    assert {split_of(s) for s in validation} == {"validation"}
    assert {split_of(s) for s in ood} == {"ood"}
    assert task.ood, "every task has an out-of-distribution set"
    # every set the evaluator runs is held out from training
    for _, _, seeds in task.eval_sets():
        assert min(seeds) >= HELD_OUT_START


def test_guard_refuses_held_out_seeds_and_allows_the_others():
    for seed in (TEST_START, TEST_START + 499, OOD_START, 2**32 - 1):
        with pytest.raises(ValueError, match=f"seed {seed} is one of the benchmark's held-out"):
            refuse_test_seeds(seed, "collect")
    with pytest.raises(ValueError, match="^collect: seed"):
        refuse_test_seeds(range(TEST_START - 5, TEST_START + 5), "collect")
    with pytest.raises(ValueError, match="harness"):
        refuse_test_seeds([1, 2, OOD_START + 3], "the algorithm harness")
    refuse_test_seeds(range(0, 1000), "collect")
    refuse_test_seeds([0, TRAIN_END - 1, VALIDATION_START, TEST_START - 1], "collect")
    refuse_test_seeds(range(0), "collect")


def test_split_seeds_refuses_an_unknown_split():
    with pytest.raises(ValueError, match="allowed"):
        split_seeds("holdout", 3)
    assert split_seeds("test", 2, offset=1) == [TEST_START + 1, TEST_START + 2]


def test_collect_refuses_test_seeds():
    with pytest.raises(ValueError, match="collect: seed .* held-out test seeds"):
        collect("GridWorld-v0", 3, seed=TEST_START - 1, progress=False)
    with pytest.raises(ValueError, match="held-out ood seeds"):
        collect("GridWorld-v0", 1, seed=OOD_START, progress=False)


def test_harness_refuses_test_seeds():
    config = harness_module.RunConfig(env_id="GridWorld-v0", eval_episodes=2, iterations=1)
    with harness_module.Harness("bc", config) as harness:
        with pytest.raises(ValueError, match="the algorithm harness: seed"):
            harness._rollouts(SUPERVISOR, [5, TEST_START + 7])


def test_training_never_draws_a_held_out_seed(monkeypatch):
    """Every seed a whole DAgger run rolls out (demonstrations, on-policy rollouts, the
    supervisor's and the learner's evaluations) goes through the guard, and is a train seed:
    the harness draws below 2**31 - 1, under the held-out blocks."""
    seen: list[int] = []
    real = splits.refuse_test_seeds

    def spy(seeds, where):
        seen.extend(seeds)
        real(seeds, where)

    monkeypatch.setattr(harness_module, "refuse_test_seeds", spy)
    assert harness_module.SEED_BOUND <= TRAIN_END
    run_algorithm(
        "dagger", env_id="GridWorld-v0", iterations=3, eval_episodes=3, samples_per_demo=5,
        seed=123,
    )  # fmt: skip
    assert len(seen) >= 3 + 3 + 3 * 3  # rollouts and evaluations
    assert all(split_of(s) == "train" for s in seen)


def test_every_task_and_ood_set_builds():
    """The suite's kwargs are valid for their ids (construction only)."""
    for task in SUITE.tasks:
        for set_name, kwargs, seeds in task.eval_sets(episodes=1):
            env = gym.make(task.env_id, **kwargs)
            assert len(seeds) == 1, set_name
            env.close()


def test_a_test_only_suite_is_shortened_and_keeps_the_test_split():
    assert not SUITE.shortened and not SUITE.select().shortened
    test_only = SUITE.select(ood=False)
    assert test_only.shortened and test_only.to_dict()["shortened"]
    for full, task in zip(SUITE.tasks, test_only.tasks, strict=True):
        assert task.ood == () and [name for name, _, _ in task.eval_sets()] == ["test"]
        assert task.eval_sets()[0] == full.eval_sets()[0]  # the same test episodes
    assert SUITE.select(tasks=list(reversed(TASK_NAMES))).shortened is False  # order only
    with pytest.raises(ValueError, match="ood is 'no'"):
        SUITE.select(ood="no")
