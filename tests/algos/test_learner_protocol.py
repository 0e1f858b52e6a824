"""Any object with fit/predict trains in every algorithm (the learner protocol)."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pytest
from learner_double import NearestLabel
from point_mass_env import ENV_ID as POINT_MASS

import fluids_bench  # noqa: F401
from fluids_bench.algos import dart, shiv
from fluids_bench.algos.learners import Learner, LearnerPolicy, SklearnLearner, resolve_factory
from fluids_bench.algos.registry import ALGORITHMS, run_algorithm

GRID = {"env_id": "GridWorld-v0", "env_kwargs": {"world_seed": 3}}
SMALL = {"iterations": 2, "eval_episodes": 2, "samples_per_demo": 15}


def test_the_double_and_the_sklearn_learner_satisfy_the_protocol() -> None:
    assert isinstance(NearestLabel(), Learner)
    assert isinstance(SklearnLearner("tree"), Learner)
    assert not isinstance(object(), Learner)


@pytest.mark.parametrize("name", sorted(ALGORITHMS))
@pytest.mark.parametrize("env_id", ["GridWorld-v0", POINT_MASS])
def test_every_algorithm_trains_a_user_learner(name: str, env_id: str) -> None:
    settings: dict[str, Any] = {"env_id": env_id, **SMALL}
    if env_id == "GridWorld-v0":
        settings["env_kwargs"] = {"world_seed": 3}
    if name == "dart":
        settings["update_at"] = (1, 2)
    learner = NearestLabel()
    result = run_algorithm(name, seed=2, policy=learner, **settings)
    assert learner.fits, "the algorithm never fit the user's learner"
    assert learner.predicts, "the user's learner never acted or was never evaluated"
    assert isinstance(result.policy, LearnerPolicy) and result.policy.learner is learner
    discrete = env_id == "GridWorld-v0"
    assert learner.label_dtypes == ({"i"} if discrete else {"f"})
    assert result.final.normalised_performance is not None
    record = json.loads(json.dumps(result.to_dict()))
    assert record["config"]["policy"] == {"learner": "learner_double:NearestLabel"}


def test_a_factory_gives_each_run_a_fresh_learner_and_the_same_records() -> None:
    a = run_algorithm("dagger", seed=1, policy=NearestLabel, **GRID, **SMALL)
    b = run_algorithm("dagger", seed=1, policy=NearestLabel, **GRID, **SMALL)
    assert a.policy.learner is not b.policy.learner
    assert a.to_dict(include_timing=False) == b.to_dict(include_timing=False)


def test_dart_estimates_its_noise_from_the_learners_predictions_on_held_out_states() -> None:
    learner = NearestLabel()
    config = dart.DARTConfig(
        env_id=POINT_MASS, policy=learner, iterations=2, update_at=(1,), eval_episodes=1,
        samples_per_demo=10,
    )  # fmt: skip
    result = dart.run(config)
    # the update predicts every held-out pair (the episodes are longer than 10 steps)
    first = result.records[0]  # iteration 1, after which DART updates
    assert first.estimation_labels > 0 and first.estimation_labels in learner.predicts
    assert first.extras["estimated_trace"] > 0.0


def test_shiv_risk_model_needs_only_predict_on_the_training_states() -> None:
    learner = NearestLabel()
    config = shiv.SHIVConfig(**GRID, policy=learner, iterations=2, eval_episodes=1)
    result = shiv.run(config)
    # the risk model asked for predictions on the whole training set before each rollout
    assert result.records[0].training_labels in learner.predicts
    assert all(r.extras["queried"] <= r.extras["visited"] for r in result.records[1:])


def test_ogd_steps_a_user_learner_on_the_latest_pairs_only() -> None:
    learner = NearestLabel()
    result = run_algorithm("ogd", policy=learner, seed=0, env_id=POINT_MASS, **SMALL)
    # each step sees one iteration's pairs (15 per demo), never the aggregate
    assert learner.fits == [15, 15, 15]
    assert result.final.training_labels == 45


def test_predictions_are_cast_and_clipped_to_the_action_space() -> None:
    from gymnasium import spaces

    class Wild:
        def fit(self, observations: np.ndarray, labels: np.ndarray) -> None: ...

        def predict(self, observations: np.ndarray) -> np.ndarray:
            return np.full((len(observations), 2), 7.5)

    box = LearnerPolicy(Wild(), spaces.Box(-1.0, 1.0, (2,), np.float32))
    assert box.predict(np.zeros((3, 4))).tolist() == [[1.0, 1.0]] * 3
    assert box.act(np.zeros(4)).dtype == np.float32


@pytest.mark.parametrize(
    ("policy", "message"),
    [(3, "a PolicySpec, a learner"), ("tree", "a PolicySpec, a learner")],
)
def test_a_bad_policy_is_refused_naming_the_field(policy: Any, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ALGORITHMS["bc"].config_class(policy=policy)


def test_a_factory_that_returns_no_learner_is_refused_clearly() -> None:
    with pytest.raises(ValueError, match="is not a learner"):
        run_algorithm("bc", policy=lambda: object(), **GRID, **SMALL)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("no_colon", "is not a learner factory"),
        ("no_such_module_xyz:make", "does not import"),
        ("learner_double:missing", "has no attribute 'missing'"),
        ("learner_double:NOT_A_FACTORY", "is not callable"),
    ],
)
def test_bad_factory_specs_are_refused_clearly(spec: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        resolve_factory(spec)
