"""Each algorithm's defining behaviour on tiny budgets, on Discrete and Box envs, bit for bit."""

from __future__ import annotations

import json
from dataclasses import replace
from typing import Any

import numpy as np
import pytest
from point_mass_env import ENV_ID as POINT_MASS

import fluids_bench  # noqa: F401
from fluids_bench.algos import bc, dagger, dart, noise, ogd, shiv
from fluids_bench.algos.dataset import Trajectory
from fluids_bench.algos.harness import Harness, make_env
from fluids_bench.algos.policies import PolicySpec
from fluids_bench.algos.query import SELECTORS
from fluids_bench.algos.registry import ALGORITHMS, run_algorithm

GRID = {"env_id": "GridWorld-v0", "env_kwargs": {"world_seed": 3}}
SMALL = {"iterations": 3, "eval_episodes": 3}
TREE = PolicySpec("tree", {"max_depth": 100})


@pytest.fixture
def collected(monkeypatch: pytest.MonkeyPatch) -> list[Trajectory]:
    """Every trajectory any harness collects during the test, in order."""
    trajectories: list[Trajectory] = []
    original = Harness.collect_many

    def spy(self: Harness, actor: Any, count: int) -> list[Trajectory]:
        batch = original(self, actor, count)
        trajectories.extend(batch)
        return batch

    monkeypatch.setattr(Harness, "collect_many", spy)
    return trajectories


def test_bc_aggregates_supervisor_demonstrations(collected: list[Trajectory]) -> None:
    result = bc.run(bc.BCConfig(**GRID, **SMALL, policy=TREE))
    assert len(collected) == 3
    for t in collected:
        np.testing.assert_array_equal(t.actions, t.labels)
    assert [r.labels_requested for r in result.records] == [30, 60, 90]
    assert [r.demonstrations for r in result.records] == [1, 2, 3]
    X, _ = result.dataset.arrays()
    np.testing.assert_array_equal(X, np.concatenate([t.states for t in collected]))
    final = result.final
    assert final.normalised_performance == pytest.approx(
        final.eval_return / result.supervisor_return
    )


def test_normalised_performance_is_exactly_one_for_a_learner_that_copies_the_supervisor() -> None:
    # on the DAG a tree fits the supervisor's labels on every node it can reach, so the learner
    # acts exactly like the supervisor on the same evaluation seeds
    config = bc.BCConfig(env_id="DAG-v0", policy=TREE, iterations=30, eval_episodes=20)
    assert bc.run(config).final.normalised_performance == 1.0


def test_evaluation_schedule_eval_at_and_eval_every() -> None:
    at = dagger.run(dagger.DAggerConfig(**GRID, iterations=5, eval_episodes=1, eval_at=(0, 3)))
    assert [r.iteration for r in at.evaluated()] == [0, 3, 5]  # the last one always
    every = bc.run(bc.BCConfig(**GRID, iterations=5, eval_episodes=1, eval_every=2))
    assert [r.iteration for r in every.evaluated()] == [2, 4, 5]
    assert all(r.normalised_performance is None for r in every.records if r.eval_return is None)


def test_evaluating_more_often_does_not_change_what_is_learned() -> None:
    # DAgger-B between refits needs evaluation-only fits; they must not shift the random
    # state of the fits that choose the next rollouts
    mlp = PolicySpec("mlp", {"hidden_layer_sizes": [8], "max_iter": 20})  # init is random
    common = {**GRID, "iterations": 6, "eval_episodes": 1, "policy": mlp}
    config = dagger.DAggerConfig(**common, retrain_at=(3,), seed=1)
    often = dagger.run(replace(config, eval_every=1))
    rarely = dagger.run(replace(config, eval_at=()))
    for a, b in zip(often.dataset.arrays(), rarely.dataset.arrays(), strict=True):
        assert a.tobytes() == b.tobytes()


def test_subsampling_keeps_50_pairs_per_demonstration() -> None:
    config = bc.BCConfig(**GRID, **SMALL, policy=TREE, samples_per_demo=10)
    assert bc.run(config).final.labels_requested == 30


def test_dagger_executes_the_learner_and_records_the_supervisor(
    collected: list[Trajectory],
) -> None:
    # the constant class predicts the initial demonstration's majority move everywhere
    config = dagger.DAggerConfig(**GRID, **SMALL, policy=PolicySpec("constant"), beta=0.0)
    result = dagger.run(config)
    initial, on_policy = collected[0], collected[1:]
    np.testing.assert_array_equal(initial.actions, initial.labels)
    majority = np.bincount(initial.labels, minlength=5).argmax()
    first = on_policy[0]
    assert np.all(first.actions == majority)
    table = make_env("GridWorld-v0", {"world_seed": 3}).unwrapped.supervisor_policy
    for t in on_policy:
        expected = [table[int(x) * 15 + int(y)] for x, y in t.states]
        np.testing.assert_array_equal(t.labels, expected)
    _, labels = result.dataset.arrays()
    np.testing.assert_array_equal(labels, np.concatenate([t.labels for t in collected]))
    assert result.final.labels_requested == 4 * 30


def test_dagger_with_beta_one_collects_what_bc_collects() -> None:
    common = {**GRID, "eval_episodes": 2, "policy": TREE, "seed": 5}
    by_bc = bc.run(bc.BCConfig(**common, iterations=4))
    by_dagger = dagger.run(dagger.DAggerConfig(**common, iterations=3, beta=1.0))
    for a, b in zip(by_bc.dataset.arrays(), by_dagger.dataset.arrays(), strict=True):
        assert a.tobytes() == b.tobytes()
    assert [r.collection_return for r in by_bc.records] == [
        r.collection_return for r in by_dagger.records
    ]


def test_dagger_b_refits_only_at_the_chosen_iterations(fits: list[int]) -> None:
    dagger.run(dagger.DAggerConfig(**GRID, iterations=5, eval_episodes=1, policy=TREE))
    assert fits == [30, 60, 90, 120, 150, 180]
    fits.clear()
    result = dagger.run(
        dagger.DAggerConfig(**GRID, iterations=5, eval_episodes=1, policy=TREE, retrain_at=(2, 4))
    )
    assert fits == [30, 90, 150]  # initial, after iteration 2, after iteration 4
    assert result.algo == "dagger_b"


def test_exponential_beta_schedule_decays_as_beta_to_the_k() -> None:
    config = dagger.DAggerConfig(
        **GRID, **SMALL, policy=TREE, beta=0.5, beta_schedule="exponential"
    )
    betas = [r.extras["beta"] for r in dagger.run(config).records]
    assert betas == [1.0, 0.5, 0.25, 0.125]


def test_discrete_noise_injection_executes_another_action_at_rate_epsilon(
    collected: list[Trajectory],
) -> None:
    noise.run(noise.NoiseConfig(**GRID, iterations=40, eval_episodes=1, eval_every=50, epsilon=0.3))
    flips = np.concatenate([t.actions != t.labels for t in collected])
    assert len(flips) == 1200 and abs(flips.mean() - 0.3) < 0.04


def test_gaussian_noise_injection_on_box_actions(collected: list[Trajectory]) -> None:
    config = noise.NoiseConfig(
        env_id=POINT_MASS, iterations=20, eval_episodes=1, eval_every=50, noise_std=0.1
    )
    noise.run(config)
    actions = np.concatenate([t.actions for t in collected])
    labels = np.concatenate([t.labels for t in collected])
    inside = np.all(np.abs(labels) < 0.6, axis=1)  # clipping at +-1 is rare there
    diff = actions[inside] - labels[inside]
    assert len(diff) > 150
    np.testing.assert_allclose(np.cov(diff.T), 0.01 * np.eye(2), atol=0.004)


def test_dart_covariance_is_eq3_and_equals_the_sample_covariance_of_centred_errors() -> None:
    rng = np.random.default_rng(0)
    errors = rng.normal(size=(200, 3))
    errors -= errors.mean(axis=0)  # zero-mean disagreements
    supervisor = rng.normal(size=(200, 3))
    sigma = dart.disagreement_covariance(supervisor + errors, supervisor)
    np.testing.assert_allclose(sigma, np.cov(errors.T, bias=True), atol=1e-12)
    shifted = errors + 1.0  # with a bias Eq. 3 is the second moment about the supervisor
    sigma = dart.disagreement_covariance(supervisor + shifted, supervisor)
    np.testing.assert_allclose(sigma, shifted.T @ shifted / 200, atol=1e-12)
    scaled = dart.scale_to_trace(sigma, 0.7)
    assert np.trace(scaled) == pytest.approx(0.7)
    np.testing.assert_allclose(scaled / scaled[0, 0], sigma / sigma[0, 0])
    assert np.array_equal(dart.scale_to_trace(np.zeros((2, 2)), 0.7), np.zeros((2, 2)))


def test_dart_disagreement_probability() -> None:
    learner = np.array([0, 1, 2, 2, 4, 4, 0, 1])
    supervisor = np.array([0, 1, 2, 3, 3, 4, 0, 0])
    assert dart.disagreement_probability(learner, supervisor) == 3 / 8


def test_dart_injects_its_estimated_noise_after_the_update(collected: list[Trajectory]) -> None:
    config = dart.DARTConfig(
        env_id=POINT_MASS,
        policy=PolicySpec("linear_svm"),
        iterations=3,
        eval_episodes=1,
        samples_per_demo=10,
        update_at=(1,),
        alpha=0.05,
    )
    result = dart.run(config)
    levels = [r.extras["noise_level"] for r in result.records]
    assert levels == pytest.approx([0.05, 0.05, 0.05])
    first, later = collected[0], collected[1:]
    np.testing.assert_array_equal(first.actions, first.labels)  # initial noise is zero
    for t in later:
        assert not np.array_equal(t.actions, t.labels)
    # training pairs (10 per demo) and held-out pairs (the other 10) are both requested
    assert result.final.labels_requested == 3 * 20
    assert len(result.dataset) == 30


def test_dart_on_discrete_actions_estimates_a_disagreement_probability() -> None:
    with pytest.raises(ValueError, match="heldout_fraction"):
        dart.run(dart.DARTConfig(**GRID, **SMALL, update_at=(1,)))
    config = dart.DARTConfig(
        **GRID, **SMALL, update_at=(2,), heldout_fraction=0.3, policy=PolicySpec("linear_svm")
    )
    levels = [r.extras["noise_level"] for r in dart.run(config).records]
    assert levels[0] == 0.0 and 0.0 < levels[1] <= 1.0 and levels[2] == levels[1]
    with pytest.raises(ValueError, match="alpha"):
        dart.run(replace(config, alpha=1.0))


def test_shiv_asks_for_fewer_labels_than_dagger_on_the_same_seed() -> None:
    common = {**GRID, "iterations": 6, "eval_episodes": 2, "policy": TREE}
    by_shiv = shiv.run(shiv.SHIVConfig(**common))
    by_dagger = dagger.run(dagger.DAggerConfig(**common))
    assert by_shiv.final.labels_requested < by_dagger.final.labels_requested
    for record in by_shiv.records[1:]:
        assert record.extras["queried"] <= record.extras["visited"] == 30


@pytest.mark.parametrize("selector", SELECTORS)
def test_every_query_selector_runs_in_the_shiv_loop(selector: str) -> None:
    result = shiv.run(shiv.SHIVConfig(**GRID, **SMALL, selector=selector, policy=TREE))
    queried = sum(r.extras["queried"] for r in result.records[1:])
    assert result.final.labels_requested == 30 + queried


def test_ogd_gradient_matches_finite_differences_for_both_action_kinds() -> None:
    rng = np.random.default_rng(0)
    X = rng.normal(size=(30, 2))
    for env_id, labels in (
        ("GridWorld-v0", rng.integers(0, 5, 30)),
        (POINT_MASS, rng.uniform(-1, 1, (30, 2))),
    ):
        space = make_env(env_id, {}).action_space
        policy = ogd.LinearPolicy.zeros(space, X)
        policy.weights = rng.normal(size=policy.weights.shape)
        analytic = policy.gradient(X, labels)

        def loss(weights: np.ndarray, policy: ogd.LinearPolicy = policy, labels=labels) -> float:
            scores = policy.phi(X) @ weights
            if policy.discrete:
                scores = scores - scores.max(axis=1, keepdims=True)
                log_p = scores - np.log(np.exp(scores).sum(axis=1, keepdims=True))
                return float(-np.mean(log_p[np.arange(30), labels]))
            return float(np.mean(np.sum((scores - labels) ** 2, axis=1)))

        numeric = np.zeros_like(analytic)
        for index in np.ndindex(analytic.shape):
            step = np.zeros_like(analytic)
            step[index] = 1e-6
            numeric[index] = (loss(policy.weights + step) - loss(policy.weights - step)) / 2e-6
        np.testing.assert_allclose(analytic, numeric, atol=1e-6)
        stepped = policy.step(X, labels, 0.1)
        assert loss(stepped.weights) < loss(policy.weights)


def test_ogd_steps_on_the_latest_iteration_only(fits: list[int]) -> None:
    result = ogd.run(ogd.OGDConfig(env_id=POINT_MASS, iterations=4, eval_episodes=2))
    assert fits == []  # no refit on the aggregate: one gradient step per iteration
    assert [r.labels_requested for r in result.records] == [20, 40, 60, 80, 100]
    assert isinstance(result.policy, ogd.LinearPolicy)


ALL = sorted(ALGORITHMS)


@pytest.mark.parametrize("name", ALL)
@pytest.mark.parametrize("env_id", ["GridWorld-v0", POINT_MASS])
def test_same_seed_same_result_bit_for_bit_on_discrete_and_box_envs(name: str, env_id: str) -> None:
    # the linear SVM's solver is randomised; the tree keeps the continuous runs quick
    policy = PolicySpec("linear_svm") if env_id == "GridWorld-v0" else PolicySpec("tree")
    settings: dict[str, Any] = {
        "env_id": env_id,
        "iterations": 3,
        "eval_episodes": 2,
        "policy": policy,
        "samples_per_demo": 15,
    }
    if name == "dart":
        settings["update_at"] = (1, 2)
    a = run_algorithm(name, seed=4, **settings)
    b = run_algorithm(name, seed=4, **settings)
    assert a.to_dict(include_timing=False) == b.to_dict(include_timing=False)
    for x, y in zip(a.dataset.arrays(), b.dataset.arrays(), strict=True):
        assert x.tobytes() == y.tobytes()
    json.dumps(a.to_dict(), allow_nan=False)
    c = run_algorithm(name, seed=5, **settings)
    assert c.dataset.arrays()[0].tobytes() != a.dataset.arrays()[0].tobytes()


def test_normalised_performance_is_none_when_the_supervisor_does_not_beat_the_floor() -> None:
    result = bc.run(bc.BCConfig(**GRID, iterations=1, eval_episodes=2, return_floor=1e6))
    assert result.final.normalised_performance is None
    json.dumps(result.to_dict(), allow_nan=False)


@pytest.mark.parametrize(
    ("config_class", "field", "value"),
    [
        (bc.BCConfig, "iterations", 0),
        (bc.BCConfig, "samples_per_demo", 0),
        (bc.BCConfig, "eval_episodes", 1.5),
        (bc.BCConfig, "seed", -1),
        (bc.BCConfig, "policy", "tree"),
        (bc.BCConfig, "eval_at", (3, 1)),
        (bc.BCConfig, "eval_at", [1, 2]),
        (dagger.DAggerConfig, "beta", 1.2),
        (dagger.DAggerConfig, "beta_schedule", "linear"),
        (dagger.DAggerConfig, "initial_demos", 0),
        (dagger.DAggerConfig, "retrain_at", (4, 2)),
        (noise.NoiseConfig, "epsilon", 2.0),
        (noise.NoiseConfig, "noise_std", -1.0),
        (dart.DARTConfig, "alpha", -1.0),
        (dart.DARTConfig, "update_at", (0,)),
        (dart.DARTConfig, "heldout_fraction", 1.0),
        (shiv.SHIVConfig, "selector", "random"),
        (shiv.SHIVConfig, "nu", 0.0),
        (shiv.SHIVConfig, "sigma", 0.0),
        (ogd.OGDConfig, "learning_rate", 0.0),
    ],
)
def test_bad_config_values_name_the_field_and_what_is_allowed(
    config_class: type, field: str, value: object
) -> None:
    with pytest.raises(ValueError, match=rf"{config_class.__name__}: field '{field}' is .*allowed"):
        config_class(**{field: value})


@pytest.mark.parametrize(
    ("env_id", "message"),
    [
        ("NoSuchEnv-v0", "allowed: the suite's ids"),
        ("CartPole-v1", "no supervisor_action"),
        ("FrozenLake-v1", "Box observation space"),
    ],
)
def test_envs_an_algorithm_cannot_use_are_refused_clearly(env_id: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        make_env(env_id, {})
