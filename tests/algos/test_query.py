"""SHIV's risk (Eq. 7-8) and the ch. 6 query-selection baselines on constructed data."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

import fluids_bench  # noqa: F401
from fluids_bench.algos.actors import SUPERVISOR, LearnerActor
from fluids_bench.algos.policies import PolicySpec, fit_policy
from fluids_bench.algos.query import (
    CommitteeSelector,
    ConfidenceSelector,
    MMDSelector,
    NoveltySelector,
    ShivSelector,
    surrogate_loss,
)
from fluids_bench.algos.rollout import rollout

DISCRETE = spaces.Discrete(2)
BOX = spaces.Box(-1.0, 1.0, (1,), np.float64)


class FixedPolicy:
    """A learner whose predictions we choose: class 1 on x > 0, class 0 elsewhere."""

    def predict(self, observations: np.ndarray) -> np.ndarray:
        return (np.asarray(observations)[:, 0] > 0).astype(np.int64)

    def act(self, observation: np.ndarray) -> int:
        return int(self.predict(np.asarray(observation)[None])[0])


def cluster(centre: tuple[float, float], n: int, seed: int) -> np.ndarray:
    return np.asarray(centre) + np.random.default_rng(seed).normal(0, 0.3, (n, 2))


def training_set() -> tuple[np.ndarray, np.ndarray]:
    """Two clusters the learner predicts right and one (around (3, 3)) it gets wrong."""
    good_left, good_right = cluster((-3, 0), 40, 0), cluster((3, -3), 40, 1)
    bad = cluster((3, 3), 40, 2)  # learner says 1 there, supervisor says 0
    X = np.vstack([good_left, good_right, bad])
    y = np.concatenate([np.zeros(40), np.ones(40), np.zeros(40)]).astype(np.int64)
    return X, y


def test_shiv_queries_every_novel_state_and_every_state_in_a_mispredicted_region() -> None:
    X, y = training_set()
    selector = ShivSelector(discrete=True, nu=0.1, sigma=1.0, nu_r=0.1, sigma_r=1.0)
    selector.fit(X, y, FixedPolicy())
    novel = np.array([[10.0, 10.0], [-10.0, 5.0], [0.0, 12.0], [-3.0, 6.0]])
    mispredicted_region = cluster((3, 3), 30, 5)[:30]
    core = np.linalg.norm(mispredicted_region - [3, 3], axis=1) < 0.5
    assert selector.risky(novel).all()
    assert selector.risky(mispredicted_region[core]).all()
    # the cores of the well-predicted clusters are safe
    assert not selector.risky(np.array([[-3.0, 0.0], [3.0, -3.0]])).any()


def test_novelty_alone_does_not_carve_out_the_mispredicted_region() -> None:
    X, y = training_set()
    selector = NoveltySelector(nu=0.1, sigma=1.0)
    selector.fit(X, y, FixedPolicy())
    assert selector.risky(np.array([[10.0, 10.0]])).all()
    assert not selector.risky(np.array([[3.0, 3.0]])).any()  # SHIV would ask here


def test_a_single_mispredicted_state_is_still_a_hole() -> None:
    X = np.vstack([cluster((0, 0), 60, 3), [[0.0, 0.0]]])
    y = np.append((X[:-1, 0] > 0).astype(np.int64), 1 - int(X[-1, 0] > 0))
    selector = ShivSelector(discrete=True)
    selector.fit(X, y, FixedPolicy())
    assert selector.risky(X[-1:]).all()


def test_shiv_asks_for_fewer_states_than_dagger_on_a_fixed_rollout() -> None:
    env = gym.make("GridWorld-v0", world_seed=2)
    demos = [rollout(env, SUPERVISOR, s) for s in range(6)]
    X = np.concatenate([d.states for d in demos])
    y = np.concatenate([d.labels for d in demos])
    policy = fit_policy(PolicySpec("tree"), env.action_space, X, y, 0)
    selector = ShivSelector(discrete=True, sigma=1.0, sigma_r=1.0)
    selector.fit(X, y, policy)
    fixed = rollout(env, LearnerActor(policy), seed=99)
    risky = selector.risky(fixed.states)
    dagger_queries = len(fixed)  # DAgger labels every visited state
    assert 0 < risky.sum() < dagger_queries
    # every visited state that is novel to the training data is among SHIV's queries
    seen = {x.tobytes() for x in X}
    novel = np.array([x.tobytes() not in seen for x in fixed.states])
    assert risky[novel].all()


def test_box_actions_use_the_median_l2_error_as_epsilon() -> None:
    rng = np.random.default_rng(6)
    X = np.concatenate([rng.normal(-1.0, 0.3, 60), rng.normal(1.5, 0.2, 20)])[:, None]
    labels = 0.1 * X
    labels[X[:, 0] > 1.0] = 0.9  # the learner below predicts 0.1 x: wrong on x > 1

    class Linear:
        def predict(self, observations: np.ndarray) -> np.ndarray:
            return 0.1 * np.asarray(observations)

        def act(self, observation: np.ndarray) -> np.ndarray:
            return self.predict(observation[None])[0]

    loss = surrogate_loss(Linear().predict(X), labels, discrete=False)
    assert np.all(loss[X[:, 0] <= 1.0] == 0.0) and np.all(loss[X[:, 0] > 1.0] > 0.4)
    selector = ShivSelector(discrete=False, sigma=0.3, sigma_r=0.3)
    selector.fit(X, labels, Linear())
    assert selector.risky(np.array([[1.5]])).all()
    assert not selector.risky(np.array([[-1.0]])).any()


def test_confidence_flags_states_near_the_hyperplane() -> None:
    rng = np.random.default_rng(0)
    X = rng.uniform(-3, 3, (200, 2))
    y = (X[:, 0] + 0.3 * rng.normal(size=200) > 0).astype(np.int64)  # noisy near x = 0
    selector = ConfidenceSelector(DISCRETE, np.random.default_rng(1))
    selector.fit(X, y, FixedPolicy())
    assert selector.threshold > 0
    assert selector.risky(np.array([[0.0, 0.0]])).all()
    assert not selector.risky(np.array([[3.0, 0.0], [-3.0, 1.0]])).any()


def test_committee_disagrees_only_where_its_members_differ() -> None:
    rng = np.random.default_rng(0)
    X = rng.uniform(-3, 3, (200, 2))
    y = (X[:, 0] + 0.5 * rng.normal(size=200) > 0).astype(np.int64)
    selector = CommitteeSelector(DISCRETE, np.random.default_rng(2))
    selector.fit(X, y, FixedPolicy())
    assert len(selector.committee) == 3
    far = np.array([[3.0, 0.0], [-3.0, 0.0]])
    assert not selector.risky(far).any()
    probe = np.column_stack([np.linspace(-0.5, 0.5, 201), np.zeros(201)])
    votes = np.stack([m.predict(probe) for m in selector.committee])
    np.testing.assert_array_equal(selector.risky(probe), np.any(votes != votes[0], axis=0))


def test_mmd_flags_states_far_from_the_data() -> None:
    X = cluster((0, 0), 100, 4)
    selector = MMDSelector(nu=0.1, sigma=1.0)
    selector.fit(X, np.zeros(100), FixedPolicy())
    assert selector.risky(np.array([[6.0, 6.0]])).all()
    assert not selector.risky(np.array([[0.0, 0.0]])).any()
    assert abs(selector.risky(X).mean() - 0.1) <= 0.02


@pytest.mark.parametrize("selector", [ConfidenceSelector, CommitteeSelector])
def test_class_based_baselines_refuse_box_actions(selector: type) -> None:
    with pytest.raises(ValueError, match="Discrete action spaces"):
        selector(BOX, np.random.default_rng(0))
