"""Singulation-v0's object_size_scale: the objects' size as a perturbation (scaled vertices,
the singulation distance scaled with them), validated, solvable by the supervisor; the default
is the nominal world (the bit-for-bit check of the defaults is in tests/sweep/test_perturbations)."""

from __future__ import annotations

import pickle

import gymnasium as gym
import numpy as np
import pytest
import shapely

import fluids_bench  # noqa: F401
from fluids_bench.algos.actors import SUPERVISOR
from fluids_bench.algos.rollout import rollout
from fluids_bench.tasks.singulation.sim import (
    OBJECT_SHAPES,
    SceneConfig,
    is_singulated,
    object_polygon,
    object_shapes,
    sample_cluster,
)
from fluids_bench.tasks.singulation.supervisor import polygons

ENV_ID = "Singulation-v0"


def test_scale_one_is_the_nominal_shapes_and_other_scales_scale_every_length() -> None:
    assert object_shapes(1.0) is OBJECT_SHAPES
    for scale in (0.5, 1.25):
        for nominal, scaled in zip(OBJECT_SHAPES, object_shapes(scale), strict=True):
            np.testing.assert_allclose(scaled, nominal * scale, rtol=0, atol=1e-15)
            area = shapely.Polygon(scaled).area / shapely.Polygon(nominal).area
            assert area == pytest.approx(scale**2, rel=1e-12)
        assert SceneConfig(object_size_scale=scale).singulation_distance == pytest.approx(
            0.10 * scale
        )


@pytest.mark.parametrize("scale", [0.5, 0.75, 1.5])
def test_scaled_clusters_touch_and_are_never_singulated_at_the_scaled_distance(scale) -> None:
    config = SceneConfig(object_size_scale=scale)
    rng = np.random.default_rng(4)
    for _ in range(20):
        poses = sample_cluster(config, rng)
        assert not is_singulated(poses[:, :2], config.singulation_distance)
        polys = [shapely.Polygon(object_polygon(i, *poses[i], scale)) for i in range(4)]
        for i, p in enumerate(polys):
            gap = p.distance(shapely.union_all([q for j, q in enumerate(polys) if j != i]))
            assert 0.0 < gap <= 1e-3  # packed touching at this size
        # the cluster's extent follows the objects' size
        spread = np.hypot(*(poses[:, :2] - poses[:, :2].mean(axis=0)).T).max()
        assert 0.04 * scale < spread < 0.15 * scale


def test_success_needs_the_scaled_distance() -> None:
    # centres on an 11 cm square: singulated at size 1 (10 cm), not at size 1.15 (11.5 cm)
    centres = [(0.0, 0.3), (0.11, 0.3), (0.0, 0.41), (0.11, 0.41)]
    state = [np.pi / 2, 0.2]
    for x, y in centres:
        state += [x, y, 0.0]
    for scale, expected in ((1.0, True), (1.15, False)):
        env = gym.make(ENV_ID, object_size_scale=scale)
        _, info = env.reset(seed=0, options={"state": state})
        assert info["progress"] == pytest.approx(0.11)  # the continuous measure: metres
        assert info["is_success"] is expected


def test_supervisor_polygons_follow_the_scale_bit_for_bit() -> None:
    rng = np.random.default_rng(6)
    poses = np.column_stack((rng.normal(0, 0.1, (4, 2)), rng.uniform(-4, 4, 4)))
    verts = polygons(poses, 1.5)
    for i, pose in enumerate(poses):
        v = object_polygon(i, *pose, 1.5)
        assert verts[i, : len(v)].tobytes() == v.tobytes()


@pytest.mark.parametrize("scale", [0.75, 1.25])
def test_supervisor_singulates_scaled_objects(scale) -> None:
    env = gym.make(ENV_ID, object_size_scale=scale)
    wins = sum(rollout(env, SUPERVISOR, 500 + s).infos[-1]["is_success"] for s in range(10))
    assert wins >= 9


def test_pixels_show_the_objects_size() -> None:
    def red_pixels(scale):
        env = gym.make(ENV_ID, obs_type="pixels", obs_size=96, object_size_scale=scale)
        obs, _ = env.reset(seed=2)
        return int(((obs[..., 0] > 150) & (obs[..., 1] < 110)).sum())

    small, nominal, large = red_pixels(0.75), red_pixels(1.0), red_pixels(1.25)
    assert small < nominal < large
    assert large / small == pytest.approx((1.25 / 0.75) ** 2, rel=0.25)  # area: the square


def test_a_scaled_env_pickles_mid_episode_and_continues_the_same() -> None:
    env = gym.make(ENV_ID, object_size_scale=1.3)
    _, info = env.reset(seed=9)
    for _ in range(8):
        _, _, _, _, info = env.step(info["supervisor_action"])
    copy = pickle.loads(pickle.dumps(env))
    for _ in range(8):
        a = env.step(info["supervisor_action"])
        b = copy.step(info["supervisor_action"])
        assert a[0].tobytes() == b[0].tobytes()
        np.testing.assert_array_equal(a[4]["supervisor_action"], b[4]["supervisor_action"])
        info = a[4]


@pytest.mark.parametrize("bad", [0.49, 1.51, float("nan"), "big", True])
def test_bad_sizes_are_refused_naming_the_argument_and_the_range(bad) -> None:
    with pytest.raises(ValueError, match=r"object_size_scale.*\[0\.5, 1\.5\]"):
        gym.make(ENV_ID, object_size_scale=bad)
