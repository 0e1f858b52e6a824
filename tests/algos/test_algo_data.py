"""Trajectories, datasets, the ch. 3 subsampling split, the rollout function and the actors."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from hypothesis import given, settings
from hypothesis import strategies as st

import fluids_bench  # noqa: F401
from fluids_bench.algos.actors import (
    SUPERVISOR,
    LearnerActor,
    MixtureActor,
    NoisySupervisorActor,
)
from fluids_bench.algos.dataset import Dataset, Trajectory, split_pairs
from fluids_bench.algos.policies import PolicySpec, fit_policy
from fluids_bench.algos.rollout import rollout

DISCRETE = spaces.Discrete(5)
BOX = spaces.Box(-1.0, 1.0, (2,), np.float64)


def constant_policy(action: int):
    X = np.zeros((3, 2), dtype=np.float32)
    return fit_policy(PolicySpec("tree"), DISCRETE, X, np.full(3, action), 0)


def test_trajectory_needs_one_more_observation_than_actions() -> None:
    with pytest.raises(ValueError, match="one more observation"):
        Trajectory(
            np.zeros((3, 2)), np.zeros(3), np.zeros(3), np.zeros(3), [{}] * 4, False, True, 0
        )


@settings(max_examples=25, deadline=None)
@given(
    n_pairs=st.integers(0, 200),
    samples=st.one_of(st.none(), st.integers(1, 80)),
    heldout_fraction=st.floats(0.0, 0.9),
    seed=st.integers(0, 2**32 - 1),
)
def test_split_is_a_partition_with_the_promised_sizes(
    n_pairs: int, samples: int | None, heldout_fraction: float, seed: int
) -> None:
    train, heldout = split_pairs(n_pairs, samples, heldout_fraction, np.random.default_rng(seed))
    assert np.array_equal(np.sort(np.concatenate([train, heldout])), np.arange(n_pairs))
    available = n_pairs - int(round(heldout_fraction * n_pairs))
    assert len(train) == (available if samples is None else min(samples, available))
    assert np.all(np.diff(train) > 0) and np.all(np.diff(heldout) > 0)


def test_split_keeps_50_per_demonstration_and_holds_out_the_rest() -> None:
    train, heldout = split_pairs(1000, 50, 0.0, np.random.default_rng(0))
    assert len(train) == 50 and len(heldout) == 950


def test_dataset_aggregates_in_order() -> None:
    data = Dataset()
    data.add(np.array([[0.0], [1.0]]), np.array([0, 1]))
    data.add(np.empty((0, 1)), np.empty(0, dtype=int))
    other = Dataset()
    other.add(np.array([[2.0]]), np.array([2]))
    data.extend(other)
    X, y = data.arrays()
    assert len(data) == 3
    np.testing.assert_array_equal(X[:, 0], [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(y, [0, 1, 2])
    with pytest.raises(ValueError, match="labels"):
        data.add(np.zeros((2, 1)), np.zeros(3))


def test_supervisor_rollout_executes_the_labels() -> None:
    env = gym.make("GridWorld-v0", world_seed=1)
    t = rollout(env, SUPERVISOR, seed=4)
    assert len(t) == 30 and len(t.observations) == 31 and len(t.infos) == 31
    np.testing.assert_array_equal(t.actions, t.labels)
    assert t.truncated and not t.terminated
    assert t.total_return == pytest.approx(t.rewards.sum())


def test_learner_rollout_executes_the_learner_and_records_the_supervisor() -> None:
    env = gym.make("GridWorld-v0", world_seed=1)
    t = rollout(env, LearnerActor(constant_policy(4)), seed=4)
    assert np.all(t.actions == 4)
    table = env.unwrapped.supervisor_policy
    expected = [table[int(x) * 15 + int(y)] for x, y in t.states]
    np.testing.assert_array_equal(t.labels, expected)
    assert not np.all(t.labels == 4)  # the supervisor does not just stay


def test_rollout_is_determined_by_the_seed_and_max_steps_cuts_it() -> None:
    env = gym.make("GridWorld-v0", world_seed=1)
    actor = MixtureActor(0.5, LearnerActor(constant_policy(0)))
    a, b = rollout(env, actor, 9), rollout(env, actor, 9)
    assert a.observations.tobytes() == b.observations.tobytes()
    assert a.actions.tobytes() == b.actions.tobytes()
    assert len(rollout(env, actor, 9, max_steps=5)) == 5


def test_mixture_extremes_are_the_supervisor_and_the_learner() -> None:
    rng = np.random.default_rng(0)
    learner = LearnerActor(constant_policy(4))
    obs = np.zeros(2, dtype=np.float32)
    assert all(MixtureActor(1.0, learner)(obs, 1, rng) == 1 for _ in range(50))
    assert all(MixtureActor(0.0, learner)(obs, 1, rng) == 4 for _ in range(50))
    picks = [MixtureActor(0.3, learner)(obs, 1, rng) for _ in range(4000)]
    assert abs(np.mean(np.array(picks) == 1) - 0.3) < 0.03


def test_epsilon_noise_replaces_the_label_with_another_action() -> None:
    rng = np.random.default_rng(1)
    always = NoisySupervisorActor(DISCRETE, epsilon=1.0)
    actions = [always(None, 2, rng) for _ in range(2000)]
    assert 2 not in actions and set(actions) == {0, 1, 3, 4}
    never = NoisySupervisorActor(DISCRETE, epsilon=0.0)
    assert all(never(None, 2, rng) == 2 for _ in range(100))
    some = NoisySupervisorActor(DISCRETE, epsilon=0.25)
    assert abs(np.mean([some(None, 2, rng) != 2 for _ in range(4000)]) - 0.25) < 0.03


def test_gaussian_noise_has_the_requested_covariance() -> None:
    covariance = np.array([[0.04, 0.01], [0.01, 0.02]])
    actor = NoisySupervisorActor(BOX, covariance=covariance)
    rng = np.random.default_rng(2)
    label = np.zeros(2)
    samples = np.array([actor(None, label, rng) for _ in range(20000)])
    np.testing.assert_allclose(np.cov(samples.T), covariance, atol=0.003)
    # far from the bounds the clip never acts; near them it does
    assert np.all(np.abs(actor(None, np.ones(2), rng)) <= 1.0)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"covariance": np.eye(3)},
        {"covariance": np.array([[1.0, 2.0], [0.0, 1.0]])},
        {"covariance": -np.eye(2)},
        {"covariance": None},
    ],
)
def test_bad_covariances_are_refused(kwargs: dict) -> None:
    with pytest.raises(ValueError, match="covariance"):
        NoisySupervisorActor(BOX, **kwargs)


def test_bad_epsilon_and_beta_are_refused() -> None:
    with pytest.raises(ValueError, match="epsilon"):
        NoisySupervisorActor(DISCRETE, epsilon=1.5)
    with pytest.raises(ValueError, match="beta"):
        MixtureActor(-0.1, SUPERVISOR)
