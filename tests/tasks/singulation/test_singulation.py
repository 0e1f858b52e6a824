"""Singulation-v0: API conformance, the arm's limits on the bodies, the success predicate, seeded
initial states, the supervisor (contract, floors with and without noise), label noise, Minari."""

from __future__ import annotations

import math
import os
import pickle
import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import shapely
from gymnasium.utils.env_checker import check_env

import fluids_bench  # noqa: F401
from fluids_bench.algos.actors import SUPERVISOR
from fluids_bench.algos.noise import isotropic_actor
from fluids_bench.algos.rollout import rollout
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.tasks.singulation.label_noise import calibrate, pearson
from fluids_bench.tasks.singulation.sim import (
    MAX_DR,
    MAX_DTHETA,
    SceneConfig,
    SingulationWorld,
    _Slide,
    is_singulated,
    joint_pose,
    object_polygon,
    progress,
    sample_cluster,
    tip_position,
)
from fluids_bench.tasks.singulation.supervisor import polygons

ENV_ID = "Singulation-v0"


def state(theta: float, r: float, centres: list[tuple[float, float]]) -> list[float]:
    """A reset state: arm pose and the four objects at ``centres`` with angle 0."""
    out = [theta, r]
    for x, y in centres:
        out += [x, y, 0.0]
    return out


@pytest.mark.parametrize("obs_type", ["state", "pixels", ["state", "pixels"]])
def test_check_env_passes_with_warnings_as_errors(obs_type) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(ENV_ID, obs_type=obs_type, render_mode="rgb_array").unwrapped)


def test_action_limits_hold_as_measured_on_the_fingertip_body() -> None:
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=0)
    c = env.config
    rng = np.random.default_rng(1)
    # mostly saturated and out-of-range actions, some small ones
    actions = np.concatenate([rng.uniform(-4, 4, (150, 2)), rng.uniform(-1, 1, (50, 2))])
    actions[:40] = [1.0, 1.0]  # drive into the joint limits
    previous = joint_pose(*env.world.tip.position)
    for a in actions:
        env.step(a.astype(np.float32))
        body = tuple(env.world.tip.position)
        theta, r = joint_pose(*body)
        assert abs(theta - previous[0]) <= MAX_DTHETA + 1e-9
        assert abs(r - previous[1]) <= MAX_DR + 1e-9
        assert c.theta_min - 1e-9 <= theta <= c.theta_max + 1e-9
        assert c.r_min - 1e-9 <= r <= c.r_max + 1e-9
        # the commanded pose is reached within the step
        assert math.dist(body, tip_position(env.world.theta, env.world.r)) < 1e-12
        previous = (theta, r)


def test_a_full_action_moves_exactly_one_and_a_half_degrees_and_one_centimetre() -> None:
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=0)
    before = joint_pose(*env.world.tip.position)
    env.step(np.array([1.0, 1.0], np.float32))
    after = joint_pose(*env.world.tip.position)
    assert after[0] - before[0] == pytest.approx(math.radians(1.5), abs=1e-12)
    assert after[1] - before[1] == pytest.approx(0.01, abs=1e-12)
    env.step(np.array([-0.5, -0.5], np.float32))
    back = joint_pose(*env.world.tip.position)
    assert back[0] - after[0] == pytest.approx(-math.radians(0.75), abs=1e-12)
    assert back[1] - after[1] == pytest.approx(-0.005, abs=1e-12)


@pytest.mark.parametrize(
    ("spacing", "expected"), [(0.1, True), (0.099, False), (0.1001, True), (0.0999, False)]
)
def test_success_predicate_on_hand_built_rows(spacing: float, expected: bool) -> None:
    # four objects in a row: every object's nearest neighbour is exactly `spacing` away
    centres = [(k * spacing, 0.5) for k in range(4)]
    env = gym.make(ENV_ID).unwrapped
    _, info = env.reset(seed=0, options={"state": state(math.pi / 2, 0.2, centres)})
    assert info["is_success"] is expected
    assert info["progress"] == pytest.approx(spacing, abs=1e-12)


def test_exactly_ten_centimetres_counts_whatever_the_float_arithmetic() -> None:
    # axis-aligned exact 0.1 and a 6-8-10 triangle whose float distance is not exactly 0.1
    assert is_singulated(np.array([[0.0, 0.0], [0.1, 0.0], [10.0, 0.0], [10.05, 0.0]]))
    assert is_singulated(np.array([[0.3, 0.4], [0.36, 0.48], [5.0, 5.0], [5.0, 5.05]]))
    assert not is_singulated(np.array([[0.0, 0.0], [0.099, 0.0], [0.198, 0.0], [0.297, 0.0]]))
    # one object 10 cm from all others, the rest packed: a success
    assert is_singulated(np.array([[0.0, 0.0], [0.05, 0.0], [0.0, 0.05], [0.0, 0.15]]))
    # 0.15 - 0.05 is 0.09999999999999999 in floats: the 1 nm tolerance makes it count
    assert progress(np.array([[0.0, 0.0], [0.05, 0.0], [0.0, 0.05], [0.0, 0.15]])) < 0.1


def test_progress_of_four_objects_equals_the_all_pairs_definition() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        centres = rng.normal(0.0, 0.06, (4, 2))
        d = np.hypot(*(centres[:, None, :] - centres[None, :, :]).transpose(2, 0, 1))
        np.fill_diagonal(d, np.inf)
        assert progress(centres) == float(d.min(axis=1).max())  # bit for bit
    # other counts take the general path
    assert progress(np.array([[0.0, 0.0], [0.3, 0.4], [0.0, 0.1]])) == pytest.approx(
        math.hypot(0.3, 0.3)
    )


def test_batched_slides_of_the_packing_answer_as_the_one_at_a_time_loops() -> None:
    # reset packs the cluster by sliding each object in (march, bisect, back off); the batched
    # versions must give exactly what the plain loops over single gap evaluations give
    rng = np.random.default_rng(4)
    for _ in range(15):
        union = shapely.Polygon(object_polygon(0, 0.0, 0.0, rng.uniform(-3, 3)))
        direction = rng.uniform(-math.pi, math.pi)
        u = np.array([math.cos(direction), math.sin(direction)])
        slide = _Slide(int(rng.integers(1, 4)), rng.uniform(-3, 3), np.zeros(2), u, union)

        def gap(t: float, slide=slide) -> float:
            return float(slide.gaps([t])[0])

        t = 0.2
        while t > 0 and gap(t) > 0.0:
            t -= 0.005
        assert slide.march(0.2, 0.005) == t
        lo, hi = t, t + 0.005
        for _ in range(14):
            mid = 0.5 * (lo + hi)
            if gap(mid) > 0.0:
                hi = mid
            else:
                lo = mid
        assert slide.bisect(t, t + 0.005, 14) == hi
        back = hi
        while gap(back) < 2e-4:
            back += 5e-5
        assert slide.back_off(hi, 5e-5, 2e-4) == back
        assert 2e-4 <= gap(back) < 2e-4 + 5e-5  # it stopped at the first clear position


def test_supervisor_polygons_are_the_objects_vertices_bit_for_bit() -> None:
    rng = np.random.default_rng(5)
    for _ in range(50):
        poses = np.column_stack((rng.normal(0, 0.1, (4, 2)), rng.uniform(-4, 4, 4)))
        verts = polygons(poses)
        for i, pose in enumerate(poses):
            v = object_polygon(i, *pose)
            assert verts[i, : len(v)].tobytes() == v.tobytes()
            assert (verts[i, len(v) :] == v[-1]).all()  # padding repeats the last vertex


def test_a_restarted_world_steps_bit_for_bit_like_a_new_one() -> None:
    # the supervisor's foresight restarts one world per candidate push instead of building one;
    # a world that pushed objects (contacts cached, solver bias velocities left on the bodies)
    # must restart into exactly the state and dynamics of a fresh build
    config = SceneConfig()
    rng = np.random.default_rng(1)
    used = SingulationWorld(config, math.radians(90), 0.2, sample_cluster(config, rng), 5)
    for _ in range(3):
        poses = sample_cluster(config, rng)
        theta, r = joint_pose(*(poses[0, :2] - [0.0, 0.07]))
        for _ in range(12):  # push up through the cluster: contacts every step
            used.step(0.0, MAX_DR)
        assert len(used.space.shapes) == 5
        used.restart(theta, r, poses)
        fresh = SingulationWorld(config, theta, r, poses, 5)
        for k in range(15):
            action = (0.3 * MAX_DTHETA * math.sin(k), MAX_DR)
            used.step(*action)
            fresh.step(*action)
            assert used.poses().tobytes() == fresh.poses().tobytes()
            assert used.tip_xy() == fresh.tip_xy()
        assert not np.allclose(fresh.poses(), poses)  # the objects were pushed


def test_seeded_resets_vary_the_scene_and_repeat_bit_for_bit() -> None:
    a, b = gym.make(ENV_ID), gym.make(ENV_ID)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (60, 2)).astype(np.float32)

    def run(env, seed):
        obs, info = env.reset(seed=seed)
        out = [obs.tobytes(), info[SUPERVISOR_ACTION_KEY].tobytes()]
        for action in actions:
            obs, reward, terminated, truncated, info = env.step(action)
            out += [obs.tobytes(), reward, terminated, info[SUPERVISOR_ACTION_KEY].tobytes()]
            if terminated:
                break
        return out

    assert run(a, 5) == run(b, 5)
    starts = {gym.make(ENV_ID).reset(seed=s)[0].tobytes() for s in range(20)}
    assert len(starts) == 20


def test_initial_clusters_touch_and_are_never_singulated() -> None:
    config = SceneConfig()
    rng = np.random.default_rng(3)
    spins = []
    for _ in range(60):
        poses = sample_cluster(config, rng)
        assert not is_singulated(poses[:, :2])
        polys = [shapely.Polygon(object_polygon(i, *poses[i])) for i in range(4)]
        for i, p in enumerate(polys):
            others = shapely.union_all([q for j, q in enumerate(polys) if j != i])
            gap = p.distance(others)
            assert 0.0 < gap <= 1e-3  # touching (a sub-millimetre gap), never overlapping
        spins.append(poses[:, :2].mean(axis=0))
    spread = np.std(spins, axis=0)
    assert np.all(spread > 0.02) and np.all(spread < 0.08)  # N(., 4.5 cm) translations


def test_supervisor_contract_and_label_for_learner_states() -> None:
    env = gym.make(ENV_ID)
    obs, info = env.reset(seed=2)
    rng = np.random.default_rng(0)
    for _ in range(25):
        label = info[SUPERVISOR_ACTION_KEY]
        again = env.unwrapped.supervisor_action()
        assert np.array_equal(label, again)
        assert np.array_equal(env.unwrapped.supervisor_action(), again)
        assert env.action_space.contains(label)
        obs, _, terminated, truncated, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        if terminated or truncated:
            break


def test_observations_do_not_alias_internal_state() -> None:
    env = gym.make(ENV_ID, obs_type=["state", "pixels"])
    obs, _ = env.reset(seed=0)
    obs["state"][:] = 0
    obs["pixels"][:] = 0
    again, *_ = env.step(np.zeros(2, np.float32))
    assert again["state"].any() and again["pixels"].any()


def test_pickle_round_trip_continues_the_same_episode() -> None:
    env = gym.make(ENV_ID)
    _, info = env.reset(seed=4)
    for _ in range(5):
        _, _, _, _, info = env.step(info[SUPERVISOR_ACTION_KEY])
    clone = pickle.loads(pickle.dumps(env))
    steps_a, steps_b = [], []
    info_a = info_b = info
    for _ in range(10):
        oa, ra, ta, _, info_a = env.step(info_a[SUPERVISOR_ACTION_KEY])
        ob, rb, tb, _, info_b = clone.step(info_b[SUPERVISOR_ACTION_KEY])
        steps_a.append((oa.tobytes(), ra, ta))
        steps_b.append((ob.tobytes(), rb, tb))
        if ta:
            break
    assert steps_a == steps_b


def test_bad_arguments_raise_value_errors_naming_them() -> None:
    with pytest.raises(ValueError, match="obs_typ"):
        gym.make(ENV_ID, obs_typ="state")
    with pytest.raises(ValueError, match="obs_type"):
        gym.make(ENV_ID, obs_type="depth")
    with pytest.raises(ValueError, match="cluster_std"):
        gym.make(ENV_ID, cluster_std=-1.0)
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(np.array([np.nan, 0.0]))
    with pytest.raises(ValueError, match="state"):
        env.reset(options={"state": [0.0, 1.0]})


def test_rendering_draws_the_scene() -> None:
    env = gym.make(ENV_ID, render_mode="rgb_array", obs_type="pixels", obs_size=64)
    obs, _ = env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (400, 400, 3) and frame.dtype == np.uint8
    assert obs.shape == (64, 64, 3)
    reds = (obs[..., 0] > 150) & (obs[..., 1] < 110)
    assert reds.sum() > 40  # the objects are visible
    other, _ = env.reset(seed=1)
    assert not np.array_equal(obs, other)


def test_supervisor_singulates_and_plans_once_per_episode_on_a_small_sample() -> None:
    env = gym.make(ENV_ID)
    wins, replans = 0, []
    for seed in range(20):
        trajectory = rollout(env, SUPERVISOR, 1000 + seed)
        wins += trajectory.infos[-1]["is_success"]
        replans.append(env.unwrapped.supervisor_stats()["replans"])
    assert wins >= 19
    assert np.mean(replans) <= 2.0  # labels between replans come from the cached plan


def test_supervisor_still_singulates_with_ten_percent_action_noise() -> None:
    env = gym.make(ENV_ID)
    actor = isotropic_actor(env.action_space, 0.1, 0.0)
    wins = sum(rollout(env, actor, 2000 + s).infos[-1]["is_success"] for s in range(20))
    assert wins >= 17


def test_supervisor_replans_when_objects_leave_the_plan() -> None:
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=0)
    plan = env._supervisor.plan
    target = plan.target
    # turn a different object by 0.2 rad under the supervisor's feet (its centre, and so the
    # progress, unchanged): the plan was made for other poses and must be redone
    other = (target + 1) % 4
    env.world.bodies[other].angle += 0.2
    env.world._poses = None  # the world reads its bodies once per step
    before = env.supervisor_stats()["replans"]
    env.supervisor_action()
    assert env.supervisor_stats()["replans"] == before + 1


def test_label_noise_model_is_calibrated_to_the_source_correlations() -> None:
    env = gym.make(ENV_ID)
    labels = np.concatenate([rollout(env, SUPERVISOR, s).labels for s in range(10)])
    model = calibrate(labels, (0.60, 0.22), seed=0)
    noisy = model.corrupt(np.repeat(labels, 50, axis=0), np.random.default_rng(1))
    measured = pearson(noisy, np.repeat(labels, 50, axis=0))
    assert measured == pytest.approx([0.60, 0.22], abs=0.03)
    assert np.all(np.abs(noisy) <= 1.0)
    same = model.corrupt(labels, np.random.default_rng(2))
    assert np.array_equal(same, model.corrupt(labels, np.random.default_rng(2)))


def test_minari_export_through_the_command_line(tmp_path: Path, monkeypatch) -> None:
    import minari

    root = tmp_path / "datasets"
    env = {**os.environ, "MINARI_DATASETS_PATH": str(root)}
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[3])
    argv = [sys.executable, "-m", "fluids_bench.cli", "collect", "--env", ENV_ID]
    argv += ["--episodes", "3", "--dataset", "test/singulation-v0", "--no-progress"]
    done = subprocess.run(argv, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))
    dataset = minari.load_dataset("test/singulation-v0")
    assert dataset.total_episodes == 3
    episode = next(dataset.iterate_episodes())
    assert episode.observations.shape[1] == 18
    assert episode.rewards[-1] == 1.0 and episode.terminations[-1]  # singulated
    assert episode.actions.shape == (len(episode.rewards), 2)
    assert dataset.recover_environment().spec.id == ENV_ID


@pytest.mark.parametrize(
    ("options", "named"),
    [
        ("abc", "options"),  # was AttributeError
        ({"stat": None}, "options"),
        ({"state": "abc"}, "state"),
        ({"state": [1j] * 14}, "state"),
        ({"state": state(math.pi / 2, -0.2, [(k * 0.12, 0.5) for k in range(4)])}, "r"),
        ({"state": state(0.0, 0.2, [(k * 0.12, 0.5) for k in range(4)])}, "theta"),
        (
            {"state": state(math.pi / 2, 0.2, [(1e9, 0.5)] + [(k * 0.12, 0.5) for k in range(3)])},
            "object 0 centre",
        ),
        (
            {
                "state": state(
                    math.pi / 2, 0.2, [(0.0, -0.3)] + [(k * 0.12, 0.5) for k in range(1, 4)]
                )
            },
            "object 0 centre",
        ),
        ({"state": state(math.pi / 2, 0.2, [(0.0, 0.5)] * 4)}, "objects 0 and 1"),  # one point
    ],
    ids=repr,
)
def test_reset_options_are_validated(options: object, named: str) -> None:
    env = gym.make(ENV_ID).unwrapped
    with pytest.raises(ValueError, match=rf"Singulation-v0: .*{named}.*allowed"):
        env.reset(seed=0, options=options)


def test_reset_state_inside_the_limits_still_starts_there() -> None:
    env = gym.make(ENV_ID).unwrapped
    _, info = env.reset(
        seed=0,
        options={
            "state": state(math.pi / 3, 0.5, [(-0.4, 0.1), (0.0, 0.3), (0.3, 0.7), (0.45, 0.05)])
        },
    )
    assert info["is_success"]
