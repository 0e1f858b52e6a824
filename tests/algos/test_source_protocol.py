"""The algorithm layer as the source defines it (issue #15): SHIV's defaults and when it
degenerates, DART's label accounting and relative alpha, compute time, protocol knobs,
evaluation metrics, and supervisors brought by the user through a wrapper."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from point_mass_env import ENV_ID as POINT_MASS
from small_fluids import SMALL_FLUIDS
from supervised_gym_envs import CARTPOLE_ID, PENDULUM_ID, cartpole_expert

import fluids_bench  # noqa: F401
from fluids_bench.algos import bc, dagger, dart, shiv
from fluids_bench.algos.actors import SUPERVISOR
from fluids_bench.algos.dataset import Trajectory
from fluids_bench.algos.evaluation import evaluate_trajectories
from fluids_bench.algos.harness import Harness, make_env
from fluids_bench.algos.plots import learning_curve_figure
from fluids_bench.algos.policies import PolicySpec
from fluids_bench.algos.query import NoveltySelector, ShivSelector
from fluids_bench.algos.rollout import rollout
from fluids_bench.core.supervisor import (
    SUPERVISOR_ACTION_KEY,
    SupervisorWrapper,
    has_supervisor,
    supervisor_action,
)

GRID = {"env_id": "GridWorld-v0", "env_kwargs": {"world_seed": 3}}
TREE = PolicySpec("tree", {"max_depth": 100})
ROOT = Path(__file__).resolve().parents[2]


# -- 1. SHIV ---------------------------------------------------------------------------------


def test_shiv_defaults_are_the_sources() -> None:
    config = shiv.SHIVConfig()
    assert (config.nu, config.nu_r, config.epsilon) == (0.1, 1e-3, None)
    assert config.sigma is None and config.sigma_r is None  # scale-aware, not sigma = 1
    selector = ShivSelector(discrete=False)
    assert selector.safe_set.nu == 0.1 and selector.mispredicted_set.nu == 1e-3
    with pytest.raises(ValueError, match="field 'sigma_r' is 2.0 while 'sigma' is None"):
        shiv.SHIVConfig(sigma_r=2.0)


def test_shiv_default_bandwidth_does_not_depend_on_the_units_of_the_observation() -> None:
    # the same states in metres and in millimetres: sigma = 1 (the old default) would call
    # every millimetre state novel; the default decides the same way in both units
    rng = np.random.default_rng(0)
    X = np.vstack([rng.normal(0, 1, (80, 3)), rng.normal(4, 0.5, (40, 3))])
    y = (X[:, 0] > 2).astype(np.int64)

    class Exact:  # predicts every training label correctly
        def predict(self, observations: np.ndarray) -> np.ndarray:
            return (np.asarray(observations)[:, 0] > 2 * scale).astype(np.int64)

    queries = np.vstack([rng.normal(0, 1, (30, 3)), rng.normal(10, 1, (10, 3))])
    decisions, bandwidths = [], []
    for scale in (1.0, 1000.0):
        selector = ShivSelector(discrete=True)
        selector.fit(X * scale, y, Exact())
        decisions.append(selector.risky(queries * scale))
        bandwidths.append(selector.sigma)  # in standardised units
    assert bandwidths[0] == pytest.approx(bandwidths[1])
    np.testing.assert_array_equal(decisions[0], decisions[1])
    assert decisions[0][30:].all()  # far-away states are queried
    assert decisions[0][:30].mean() < 0.5  # most states like the training data are not


def test_shiv_with_its_defaults_queries_fewer_states_than_dagger_on_fluids() -> None:
    # FLUIDS' raw quasi-LIDAR features are metres and m/s: with sigma = 1 on them every new
    # state looked novel; with the defaults SHIV skips states like those it was trained on
    settings = {
        **SMALL_FLUIDS,
        "iterations": 6,
        "eval_episodes": 1,
        "eval_at": (),
        "max_steps": 150,
        "return_floor": -1.0,
        "samples_per_demo": None,
        "policy": PolicySpec("tree", {"max_depth": 10}),
    }
    by_shiv = shiv.run(shiv.SHIVConfig(**settings))
    by_dagger = dagger.run(dagger.DAggerConfig(**settings))
    queried = sum(r.extras["queried"] for r in by_shiv.records[1:])
    visited = sum(r.extras["visited"] for r in by_shiv.records[1:])
    assert queried < 0.8 * visited
    assert by_shiv.final.labels_requested < 0.8 * by_dagger.final.labels_requested


def test_shiv_queries_every_risky_state_without_the_per_demonstration_cap(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    flagged: list[int] = []
    original = ShivSelector.risky

    def spy(self: ShivSelector, observations: np.ndarray) -> np.ndarray:
        mask = original(self, observations)
        flagged.append(int(mask.sum()))
        return mask

    monkeypatch.setattr(ShivSelector, "risky", spy)
    config = shiv.SHIVConfig(**GRID, iterations=4, eval_episodes=1, samples_per_demo=5)
    result = shiv.run(config)
    queried = [int(r.extras["queried"]) for r in result.records[1:]]
    assert queried == flagged  # "states queried" is what the risk model flagged, not the cap
    assert max(queried) > 5
    assert result.final.labels_requested == 5 + sum(queried)  # the initial demo is capped


def test_shiv_reduces_to_novelty_detection_only_when_the_learner_fits_its_data() -> None:
    common = {**GRID, "iterations": 4, "eval_episodes": 1, "seed": 2}

    def queries(selector: str, policy: PolicySpec) -> tuple[bytes, Any]:
        result = shiv.run(shiv.SHIVConfig(**common, selector=selector, policy=policy))
        return result.dataset.arrays()[0].tobytes(), result

    # a depth-100 tree predicts all its (consistent) training labels: no mispredicted set
    exact, exact_run = queries("shiv", TREE)
    assert all(r.extras["mispredicted"] == 0 for r in exact_run.records[1:])
    assert exact == queries("novelty", TREE)[0]
    # a linear SVM mispredicts some training states: SHIV carves them out of the safe set
    linear = PolicySpec("linear_svm")
    carved, carved_run = queries("shiv", linear)
    assert all(r.extras["mispredicted"] > 0 for r in carved_run.records[1:])
    assert carved != queries("novelty", linear)[0]


def test_novelty_selector_is_shiv_without_mispredicted_states() -> None:
    rng = np.random.default_rng(1)
    X = rng.normal(size=(100, 2))
    y = np.zeros(100, dtype=np.int64)

    class Zero:
        def predict(self, observations: np.ndarray) -> np.ndarray:
            return np.zeros(len(observations), dtype=np.int64)

    probe = rng.normal(scale=2.0, size=(200, 2))
    shiv_selector, novelty = ShivSelector(discrete=True), NoveltySelector()
    shiv_selector.fit(X, y, Zero())
    novelty.fit(X, y, Zero())
    assert shiv_selector.mispredicted == 0
    np.testing.assert_array_equal(shiv_selector.risky(probe), novelty.risky(probe))


def test_box_epsilon_is_the_median_l2_error_in_action_units() -> None:
    X = np.linspace(-1, 1, 41)[:, None]
    labels = np.zeros((41, 2))
    labels[:, 0] = 3.0 * np.abs(X[:, 0])  # the learner below predicts zeros: error 3|x|

    class Zeros:
        def predict(self, observations: np.ndarray) -> np.ndarray:
            return np.zeros((len(observations), 2))

    selector = ShivSelector(discrete=False, sigma=0.2, sigma_r=0.2, epsilon=1.5)
    selector.fit(X, labels, Zeros())
    assert selector.mispredicted == np.count_nonzero(3.0 * np.abs(X[:, 0]) > 1.5)  # L2, not L2^2
    median = ShivSelector(discrete=False, sigma=0.2, sigma_r=0.2)
    median.fit(X, labels, Zeros())
    assert median.mispredicted == 20  # above the median error


# -- 2. DART's label accounting ---------------------------------------------------------------


def test_dart_counts_training_and_noise_estimation_labels_apart() -> None:
    config = dart.DARTConfig(
        env_id=POINT_MASS,
        policy=PolicySpec("linear_svm"),
        iterations=3,
        eval_episodes=1,
        samples_per_demo=10,
        update_at=(1,),
    )
    result = dart.run(config)
    for record in result.records:
        assert record.training_labels == 10 * record.demonstrations
        assert record.estimation_labels == 10 * record.demonstrations
        assert record.labels_requested == record.training_labels + record.estimation_labels
    assert result.final.training_labels == len(result.dataset)
    by_bc = bc.run(bc.BCConfig(env_id=POINT_MASS, iterations=3, eval_episodes=1))
    assert [r.estimation_labels for r in by_bc.records] == [0, 0, 0]
    assert [r.training_labels for r in by_bc.records] == [20, 40, 60]


def test_learning_curves_plot_training_labels_or_demonstrations() -> None:
    config = dart.DARTConfig(
        env_id=POINT_MASS, iterations=2, eval_episodes=1, samples_per_demo=10, update_at=(1,)
    )
    result = dart.run(config)
    top = learning_curve_figure([result]).axes[0]
    xs = top.lines[0].get_xdata()
    np.testing.assert_array_equal(xs, [r.training_labels for r in result.evaluated()])
    assert list(xs) != [r.labels_requested for r in result.evaluated()]
    top = learning_curve_figure([result], x="demonstrations").axes[0]
    np.testing.assert_array_equal(top.lines[0].get_xdata(), [1, 2])
    with pytest.raises(ValueError, match="field 'x' is 'labels'"):
        learning_curve_figure([result], x="labels")


# -- 3. relative alpha ---------------------------------------------------------------------


def test_alpha_relative_scales_the_noise_to_a_multiple_of_an_estimated_trace() -> None:
    common = {
        "env_id": POINT_MASS,
        "policy": PolicySpec("linear_svm"),
        "iterations": 3,
        "eval_episodes": 1,
        "eval_at": (),
        "samples_per_demo": 10,
        "update_at": (1, 2),
        "initial_noise_std": 0.1,
    }
    first = dart.run(dart.DARTConfig(**common, alpha_relative=3.0)).records
    estimated = [r.extras["estimated_trace"] for r in first[:2]]
    assert estimated[0] > 0 and estimated[1] != estimated[0]
    # "alpha = 3" of ch. 5: 3 tr(Sigma_1) at every update
    assert [r.extras["noise_level"] for r in first[:2]] == pytest.approx([3 * estimated[0]] * 2)
    current = dart.run(
        dart.DARTConfig(**common, alpha_relative=2.0, alpha_reference="current")
    ).records
    for record in current[:2]:
        assert record.extras["noise_level"] == pytest.approx(2 * record.extras["estimated_trace"])
    # relative 1 to the current estimate is no prior at all
    plain = dart.run(dart.DARTConfig(**common))
    same = dart.run(dart.DARTConfig(**common, alpha_relative=1.0, alpha_reference="current"))
    assert plain.dataset.arrays()[0].tobytes() == same.dataset.arrays()[0].tobytes()
    with pytest.raises(ValueError, match="field 'alpha_relative' is 3.0 while 'alpha' is 1.0"):
        dart.DARTConfig(alpha=1.0, alpha_relative=3.0)
    with pytest.raises(ValueError, match="field 'alpha_reference' is 'last'"):
        dart.DARTConfig(alpha_reference="last")


# -- 4. computation time ---------------------------------------------------------------------


def test_wall_seconds_counts_collection_and_fitting_but_not_evaluation(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # a fake clock: every reading advances 1 ms; an evaluation takes 1000 s
    clock = {"now": 0.0}

    def perf_counter() -> float:
        clock["now"] += 1e-3
        return clock["now"]

    original = Harness.evaluate

    def slow_evaluation(self: Harness, actor: Any) -> Any:
        clock["now"] += 1000.0
        return original(self, actor)

    monkeypatch.setattr("fluids_bench.algos.harness.time.perf_counter", perf_counter)
    monkeypatch.setattr(Harness, "evaluate", slow_evaluation)
    result = dagger.run(dagger.DAggerConfig(**GRID, iterations=3, eval_episodes=1, policy=TREE))
    walls = [r.wall_seconds for r in result.records]
    assert walls == sorted(walls) and walls[-1] < 1.0  # four evaluations (4000 s) not counted
    for record in result.records:
        assert record.wall_seconds >= record.train_seconds > 0.0
    assert "wall_seconds" not in result.to_dict(include_timing=False)["records"][0]


# -- 5. protocol knobs -----------------------------------------------------------------------


def test_dart_initial_demonstrations_then_an_update_every_k(fits: list[int]) -> None:
    config = dart.DARTConfig(
        env_id=POINT_MASS,
        iterations=7,
        eval_episodes=1,
        eval_at=(),
        samples_per_demo=10,
        initial_demos=4,
        update_every=3,
    )
    result = dart.run(config)
    assert [r.iteration for r in result.records] == list(range(8))
    assert result.records[0].demonstrations == 4
    assert fits == [40, 70, 100]  # after the 4 initial demos, after iterations 3 and 6
    levels = [r.extras["noise_level"] for r in result.records]
    assert levels[0] > 0 and levels[1] == levels[2] == levels[0] and levels[3] != levels[0]


def test_dagger_b_initial_demonstrations_then_a_refit_every_k(fits: list[int]) -> None:
    config = dagger.DAggerConfig(
        **GRID, iterations=5, eval_episodes=1, eval_at=(), initial_demos=3, retrain_every=2
    )
    result = dagger.run(config)
    assert result.algo == "dagger_b" and result.records[0].demonstrations == 3
    assert fits == [90, 150, 210]  # after the initial demos, after iterations 2 and 4
    with pytest.raises(ValueError, match="field 'retrain_every' is 0"):
        dagger.DAggerConfig(retrain_every=0)
    with pytest.raises(ValueError, match="field 'update_every' is 0"):
        dart.DARTConfig(update_every=0)


def test_gridworld_reproduction_states_and_prints_the_sources_settings(tmp_path: Path) -> None:
    script = ROOT / "scripts" / "reproductions" / "reproduce_gridworld.py"
    args = ["--worlds", "1", "--iterations", "2", "--eval-episodes", "1", "--workers", "1"]
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}
    results = tmp_path / "results.json"  # never the repository's docs/results
    run = subprocess.run(
        [sys.executable, str(script), *args, "--out", str(tmp_path), "--results", str(results)],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    assert "'beta': 0.0" in run.stdout and "'initial_demos': 1" in run.stdout
    assert "'beta_schedule': 'constant'" in run.stdout
    assert "expected run time" in run.stdout
    assert (tmp_path / "worlds" / "world_000.json").exists()  # resumable per world
    written = json.loads(results.read_text())
    assert written["command"].startswith(
        "python scripts/reproductions/reproduce_gridworld.py --worlds 1"
    )
    assert written["settings"]["on_policy"]["beta"] == 0.0 and "worlds" not in written


# -- 6. evaluation metrics --------------------------------------------------------------------


def _episode(success: bool | None, collisions: list[int]) -> Trajectory:
    infos: list[dict[str, Any]] = [{"collisions": [{}] * c} for c in [0, *collisions]]
    if success is not None:
        infos[-1]["is_success"] = success
    steps = len(collisions)
    return Trajectory(
        observations=np.zeros((steps + 1, 1)),
        actions=np.zeros(steps),
        labels=np.zeros(steps),
        rewards=np.ones(steps),
        infos=infos,
        terminated=success is not None,
        truncated=success is None,
        seed=0,
    )


def test_evaluation_reports_success_collisions_and_standard_errors() -> None:
    episodes = [_episode(True, [0, 0]), _episode(False, [0, 2]), _episode(None, [1, 0, 0])]
    summary = evaluate_trajectories(episodes)
    assert summary.success_rate == pytest.approx(1 / 3)  # a truncated episode is a failure
    assert summary.success_se == pytest.approx(np.std([1, 0, 0], ddof=1) / np.sqrt(3))
    assert summary.collisions == pytest.approx(1.0)
    assert summary.mean_return == pytest.approx(7 / 3)
    assert summary.return_se == pytest.approx(np.std([2, 2, 3], ddof=1) / np.sqrt(3))
    plain = [replace(e, infos=[{} for _ in e.infos]) for e in episodes]
    assert evaluate_trajectories(plain).success_rate is None
    assert evaluate_trajectories(plain).collisions is None


def test_fluids_learning_curves_log_success_and_collisions() -> None:
    config = bc.BCConfig(
        env_id="FLUIDS-v0",
        env_kwargs={
            "action_level": "velocity",
            "obs_type": "qlidar",
            "lidar_rays": 16,
            "num_cars": 2,
            "num_pedestrians": 1,
        },
        iterations=1,
        eval_episodes=6,
        return_floor=-1.0,
        policy=PolicySpec("tree", {"max_depth": 10}),
    )
    result = bc.run(config)
    final = result.final
    assert final.eval_success_rate is not None and final.eval_collisions is not None
    assert final.eval_success_rate * 6 == pytest.approx(round(final.eval_success_rate * 6))
    assert final.eval_return_se is not None and final.eval_return_se >= 0
    assert result.supervisor_metrics["success_rate"] is not None
    # once the env has reported success, a batch of timed-out episodes scores 0, not None
    timed_out = [replace(e, infos=[{} for _ in e.infos]) for e in [_episode(None, [0])] * 2]
    assert evaluate_trajectories(timed_out, reports_success=True).success_rate == 0.0
    # GridWorld reports neither
    grid = bc.run(bc.BCConfig(**GRID, iterations=1, eval_episodes=2)).final
    assert grid.eval_success_rate is None and grid.eval_collisions is None
    assert grid.eval_return_se is not None


# -- 7. bring your own supervisor ---------------------------------------------------------


def test_a_supervisor_supplied_by_a_wrapper_is_found_through_the_chain() -> None:
    env = gym.make(CARTPOLE_ID)  # TimeLimit(OrderEnforcing(PassiveEnvChecker(Supervisor(...))))
    assert not hasattr(env.unwrapped, "supervisor_action")
    assert has_supervisor(env)
    observation, info = env.reset(seed=0)
    for _ in range(30):
        label = supervisor_action(env)
        assert info[SUPERVISOR_ACTION_KEY] == label == cartpole_expert(env)
        assert env.action_space.contains(label)
        observation, _, terminated, truncated, info = env.step(label)
        assert not (terminated or truncated)
    assert make_env(CARTPOLE_ID, {}).action_space == env.action_space
    with pytest.raises(TypeError, match="SupervisorWrapper"):
        supervisor_action(gym.make("CartPole-v1"))
    with pytest.raises(ValueError, match="supervisor is 3"):
        SupervisorWrapper(gym.make("CartPole-v1"), 3)  # type: ignore[arg-type]


def test_algorithms_run_on_gymnasium_envs_with_an_attached_supervisor() -> None:
    # Discrete: DAgger learns CartPole from the hand-written expert
    result = dagger.run(
        dagger.DAggerConfig(env_id=CARTPOLE_ID, iterations=4, eval_episodes=3, policy=TREE)
    )
    assert result.supervisor_return == 200.0
    assert result.final.normalised_performance is not None
    assert result.final.normalised_performance > 0.5
    # Box: DART on Pendulum, the labels are the expert's torques
    env = gym.make(PENDULUM_ID)
    trajectory = rollout(env, SUPERVISOR, seed=1)
    assert len(trajectory) == 100 and trajectory.labels.shape == (100, 1)
    np.testing.assert_array_equal(trajectory.actions, trajectory.labels)
    noisy = dart.run(
        dart.DARTConfig(
            env_id=PENDULUM_ID,
            iterations=2,
            eval_episodes=1,
            samples_per_demo=50,
            update_at=(1,),
            policy=PolicySpec("tree", {"max_depth": 10}),
            return_floor=-1700.0,
        )
    )
    assert noisy.records[0].extras["noise_level"] > 0.0
    assert noisy.final.estimation_labels == 100


def test_grid_search_picks_the_bandwidths_with_the_lowest_on_policy_surrogate_loss() -> None:
    config = shiv.SHIVConfig(**GRID, policy=PolicySpec("linear_svm"), eval_episodes=1, seed=1)
    tuned, trials = shiv.grid_search_bandwidths(config, sigmas=(0.3, 3.0, 30.0), episodes=3)
    assert [(t.sigma, t.sigma_r) for t in trials] == [(0.3, 0.3), (3.0, 3.0), (30.0, 30.0)]
    best = min(trials, key=lambda t: (t.surrogate_loss, t.labels, -t.sigma))
    assert (tuned.sigma, tuned.sigma_r) == (best.sigma, best.sigma_r)
    assert tuned.iterations == config.iterations  # only the bandwidths change
    # a wide kernel calls more states safe: fewer labels than a narrow one
    assert trials[2].labels < trials[0].labels
    again = shiv.grid_search_bandwidths(config, sigmas=(0.3, 3.0, 30.0), episodes=3)[1]
    assert again == trials
    with pytest.raises(ValueError, match="'sigmas' is empty"):
        shiv.grid_search_bandwidths(config, sigmas=())
