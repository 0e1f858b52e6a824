"""FLUIDS-v0 with every observation family, rendering, and the demo / render-layout commands."""

from __future__ import annotations

import sys
import warnings

import gymnasium as gym
import imageio.v2 as imageio
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import fluids_bench  # noqa: F401  (registers the env ids)
from fluids_bench.cli import main
from fluids_bench.tasks.fluids.sim.layout import build_layout, save_layout
from fluids_bench.tasks.fluids.sim.render import COLLISION, RENDER_SIZE
from fluids_bench.tasks.fluids.sim.world import Collision

# reviewed allow-list: FLUIDS' Box actions are physical, not normalised to [-1, 1]
ALLOWED_WARNINGS = (r".*symmetric and normalized",)
OBS_TYPES = [
    "explicit",
    "birdseye",
    "qlidar",
    ["birdseye", "qlidar"],
    ["explicit", "birdseye", "qlidar"],
]
ALL_NOISE = {"obs_noise": 0.5, "pixel_noise": 16.0, "lidar_noise": 0.2, "lidar_dropout": 0.2}


@pytest.fixture(autouse=True)
def _headless(monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")


def _strict_check(env) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for pattern in ALLOWED_WARNINGS:
            warnings.filterwarnings("ignore", message=pattern)
        check_env(env.unwrapped)


@pytest.mark.parametrize("obs_type", OBS_TYPES, ids=str)
def test_check_env_every_obs_type(obs_type):
    env = gym.make("FLUIDS-v0", obs_type=obs_type, render_mode="rgb_array", **ALL_NOISE)
    _strict_check(env)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    if isinstance(obs_type, list):
        assert isinstance(env.observation_space, gym.spaces.Dict) and set(obs) == set(obs_type)


def test_spaces_follow_the_sensor_kwargs():
    env = gym.make(
        "FLUIDS-v0",
        obs_type=["birdseye", "qlidar"],
        birdseye_size=128,
        lidar_rays=90,
        lidar_range=40.0,
        birdseye_frame="global",
    )
    space = env.observation_space
    assert space["birdseye"].shape == (128, 128, 3) and space["birdseye"].dtype == np.uint8
    assert space["qlidar"].shape == (90, 4) and space["qlidar"].dtype == np.float32
    assert space["qlidar"].high[0, 0] == 40.0
    obs, info = env.reset(seed=3)
    for _ in range(5):
        obs, *_, info = env.step(info["supervisor_action"])
        assert space.contains(obs)


def test_seeded_episodes_are_identical_with_every_noise_source_on():
    kwargs = dict(
        obs_type=["explicit", "birdseye", "qlidar"], num_cars=5, num_pedestrians=3, **ALL_NOISE
    )
    a, b = gym.make("FLUIDS-v0", **kwargs), gym.make("FLUIDS-v0", **kwargs)
    obs_a, info_a = a.reset(seed=11)
    obs_b, _ = b.reset(seed=11)
    other, _ = gym.make("FLUIDS-v0", **kwargs).reset(seed=12)
    assert not np.array_equal(obs_a["birdseye"], other["birdseye"])
    for _ in range(40):
        for key in obs_a:
            np.testing.assert_array_equal(obs_a[key], obs_b[key], err_msg=key)
        action = info_a["supervisor_action"]
        obs_a, _, term, trunc, info_a = a.step(action)
        obs_b, *_ = b.step(action)
        if term or trunc:
            break


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"obs_type": "lidar"}, "obs_type"),
        ({"birdseye_size": 8}, "birdseye_size"),
        ({"birdseye_fov": 0.0}, "birdseye_fov"),
        ({"birdseye_frame": "side"}, "birdseye_frame"),
        ({"pixel_noise": -1.0}, "pixel_noise"),
        ({"lidar_rays": 0}, "lidar_rays"),
        ({"lidar_range": 0.5}, "lidar_range"),
        ({"lidar_noise": -0.1}, "lidar_noise"),
        ({"lidar_dropout": 1.5}, "lidar_dropout"),
        ({"render_mode": "ascii"}, "render_mode"),
    ],
)
def test_bad_sensor_kwargs_name_the_field_and_range(kwargs, field):
    with (
        pytest.raises(ValueError, match=rf"field '{field}' is .*; allowed: .+"),
        warnings.catch_warnings(),
    ):
        warnings.simplefilter("ignore")  # gym.make's own warning about an unknown render_mode
        gym.make("FLUIDS-v0", **kwargs)


def test_rgb_array_render_shows_collisions():
    env = gym.make("FLUIDS-v0", render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (RENDER_SIZE, RENDER_SIZE, 3) and frame.dtype == np.uint8
    red = (np.abs(frame.astype(int) - COLLISION).max(axis=-1) <= 4).sum()
    world = env.unwrapped.world
    world.log.append(Collision(world.steps, 0, 1, "car-car"))  # as World.step logs one
    hit = env.render()
    assert (np.abs(hit.astype(int) - COLLISION).max(axis=-1) <= 4).sum() > red + 100
    assert env.render() is not hit  # a fresh array each call


def test_render_without_mode_warns_and_returns_none():
    env = gym.make("FLUIDS-v0")
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="render_mode"):
        assert env.unwrapped.render() is None


def test_human_mode_without_pygame_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "pygame", None)  # import pygame now fails
    with pytest.raises(ImportError, match=r'pip install "fluids-bench\[human\]"'):
        gym.make("FLUIDS-v0", render_mode="human")


def test_human_mode_opens_a_window():
    pytest.importorskip("pygame")
    env = gym.make("FLUIDS-v0", render_mode="human")
    assert "human" in env.metadata["render_modes"]
    _, info = env.reset(seed=0)
    env.step(info["supervisor_action"])
    assert env.render() is None
    window = env.unwrapped._window
    assert window.screen.get_size() == (RENDER_SIZE, RENDER_SIZE)
    env.close()
    assert env.unwrapped._window is None


def test_demo_writes_video_and_snapshot(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--steps", "12", "--seed", "1", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "success:" in text and "collisions:" in text and "steps/s" in text
    frames = imageio.mimread(out / "episode.mp4")
    assert len(frames) == 13 and frames[0].shape == (RENDER_SIZE, RENDER_SIZE, 3)
    png = imageio.imread(out / "episode.png")
    assert png.shape == (RENDER_SIZE, RENDER_SIZE, 3)
    assert (
        main(
            [
                "demo",
                "--steps",
                "3",
                "--no-video",
                "--layout",
                "roundabout",
                "--out",
                str(tmp_path / "nv"),
            ]
        )
        == 0
    )
    assert sorted(p.name for p in (tmp_path / "nv").iterdir()) == ["episode.png"]


def test_render_layout_from_builder_and_file(tmp_path, capsys):
    png = tmp_path / "t.png"
    assert (
        main(
            [
                "render-layout",
                "t_junction",
                "--lanes",
                "2",
                "--no-lights",
                "--out",
                str(png),
                "--size",
                "256",
            ]
        )
        == 0
    )
    assert imageio.imread(png).shape == (256, 256, 3)
    path = tmp_path / "mine.json"
    save_layout(build_layout("four_way", lanes=2), path)
    assert main(["render-layout", str(path), "--out", str(tmp_path / "f.png")]) == 0
    assert (tmp_path / "f.png").stat().st_size > 1000
    assert main(["render-layout", "roundabout", "--lanes", "2"]) == 2
    assert "--lanes does not apply to layout 'roundabout'" in capsys.readouterr().err
    assert main(["render-layout", "nowhere"]) == 2
