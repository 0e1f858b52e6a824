"""DrivingTrack-v0: the track generator, the car and its crash rule, the image and HOG pipeline,
the search supervisor (exactness, determinism, crash rates) and the Gymnasium contract."""

from __future__ import annotations

import itertools
import math
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
import shapely
from gymnasium.utils.env_checker import check_env

import fluids_bench  # noqa: F401
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.tasks.track.env import DrivingTrackEnv
from fluids_bench.tasks.track.features import HOG_DIM, IMAGE_SIZE, BirdsEye, hog_descriptor
from fluids_bench.tasks.track.sim import (
    TURN,
    Track,
    TrackConfig,
    TrackSim,
    generate_track,
)
from fluids_bench.tasks.track.supervisor import ORDER, SearchSupervisor

CONFIG = TrackConfig()
LEFT, STRAIGHT, RIGHT = 2, 1, 0  # action indices: +15° turns left (counter-clockwise)


def square_track(side: float = 200.0, half_width: float = 15.0) -> Track:
    v = np.array([[150.0, 150.0], [150 + side, 150.0], [150 + side, 150 + side], [150, 150 + side]])
    return Track(v, half_width)


# -- the track generator -----------------------------------------------------------------------


def test_tracks_are_convex_ccw_polygons_of_five_to_seven_edges_inside_the_workspace() -> None:
    for seed in range(200):
        track = generate_track(np.random.default_rng(seed), CONFIG)
        assert 5 <= track.edges <= 7
        polygon = shapely.Polygon(track.vertices)
        assert polygon.is_valid
        assert polygon.area == pytest.approx(polygon.convex_hull.area, rel=1e-12)  # convex
        assert shapely.Polygon(track.vertices).exterior.is_ccw
        assert track.vertices.min() >= CONFIG.half_width
        assert track.vertices.max() <= CONFIG.workspace - CONFIG.half_width


def test_tracks_are_seeded() -> None:
    a = generate_track(np.random.default_rng(7), CONFIG)
    b = generate_track(np.random.default_rng(7), CONFIG)
    c = generate_track(np.random.default_rng(8), CONFIG)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    assert a.vertices.shape != c.vertices.shape or not np.array_equal(a.vertices, c.vertices)


def test_track_seed_fixes_the_track_and_reset_seed_draws_new_ones() -> None:
    env = DrivingTrackEnv(obs_type="state", track_seed=3)
    tracks = set()
    for seed in range(3):
        env.reset(seed=seed)
        tracks.add(env.track.vertices.tobytes())
    assert len(tracks) == 1
    free = DrivingTrackEnv(obs_type="state")
    tracks = set()
    for seed in range(3):
        free.reset(seed=seed)
        tracks.add(free.track.vertices.tobytes())
    assert len(tracks) == 3


def test_projection_on_hand_made_points() -> None:
    track = square_track()
    d, arc, seg = track.project(250.0, 140.0)  # 10 below the bottom edge's middle
    assert (d, arc, seg) == (10.0, 100.0, 0)
    d, arc, seg = track.project(360.0, 250.0)  # right of the right edge
    assert (d, arc, seg) == (10.0, 300.0, 1)
    d, arc, _ = track.project(140.0, 140.0)  # outside the first corner: nearest is the vertex
    assert d == pytest.approx(math.hypot(10, 10)) and arc == 0.0
    assert track.perimeter == 800.0
    assert track.point_at(850.0) == (200.0, 150.0, 0.0)


# -- the car -----------------------------------------------------------------------------------


def test_twenty_four_left_turns_bring_the_heading_back() -> None:
    # a wide road so the car never crashes while it circles
    sim = TrackSim(square_track(300.0, 120.0), TrackConfig(half_width=120.0, speed=5.0))
    sim.place(150.0)
    start = (sim.car.x, sim.car.y, sim.car.heading)
    for _ in range(24):
        assert not sim.step(LEFT)
    assert sim.car.heading == pytest.approx(start[2], abs=1e-9)
    assert (sim.car.x, sim.car.y) == pytest.approx(start[:2], abs=1e-9)
    assert TURN == pytest.approx(math.radians(15))


def test_a_crash_puts_the_car_on_the_centre_line_ahead_heading_along_the_road() -> None:
    track = square_track()
    sim = TrackSim(track, CONFIG)
    sim.place(100.0, lateral=-14.0)  # near the outer (right-hand) edge of the bottom side
    progress = sim.car.progress
    assert sim.step(RIGHT)  # 15° towards the grass and 10 units: leaves the road
    car = sim.car
    assert car.crashes == 1
    assert track.project(car.x, car.y)[0] == pytest.approx(0.0, abs=1e-9)
    assert car.heading == pytest.approx(track.headings[0])
    # put back reset_ahead beyond the exit point's projection (x of the exit + 10)
    exit_x = 250.0 + 10.0 * math.cos(-TURN)
    assert car.x == pytest.approx(exit_x + CONFIG.reset_ahead)
    assert car.progress > progress


def test_crashes_stay_bounded_and_progress_monotone_for_a_car_that_never_steers() -> None:
    # driving straight crashes at every corner; the reset rule must not trap it in a loop
    for seed in range(10):
        track = generate_track(np.random.default_rng(seed), CONFIG)
        sim = TrackSim(track, CONFIG)
        sim.place(0.0)
        last = 0.0
        for _ in range(400):
            sim.step(STRAIGHT)
            assert sim.car.progress >= last
            last = sim.car.progress
        assert sim.laps > 2
        assert sim.car.crashes / sim.laps <= track.edges + 1


# -- the image and HOG -------------------------------------------------------------------------


def test_hog_dimension_and_observation() -> None:
    assert HOG_DIM == 20_736
    assert hog_descriptor().getDescriptorSize() == HOG_DIM
    env = DrivingTrackEnv(track_seed=1)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (HOG_DIM,) and obs.dtype == np.float32
    assert env.observation_space.contains(obs)
    assert obs.max() > 0.0


def test_patch_frames_equal_the_full_pipeline_bit_for_bit() -> None:
    rng = np.random.default_rng(0)
    view = BirdsEye(generate_track(np.random.default_rng(2), CONFIG), CONFIG.workspace)
    for _ in range(200):
        x, y = rng.uniform(-30, 530, 2)  # including the image's edges and beyond
        heading = rng.uniform(-math.pi, math.pi)
        frame = view.frame(x, y, heading)
        assert frame.shape == (IMAGE_SIZE, IMAGE_SIZE, 3)
        np.testing.assert_array_equal(frame, view.frame_reference(x, y, heading))


def test_the_car_shows_in_the_pixels() -> None:
    env = DrivingTrackEnv(obs_type="pixels", track_seed=1)
    obs, _ = env.reset(seed=0)
    obs2 = env.step(STRAIGHT)[0]
    assert not np.array_equal(obs2, obs)  # the car moved
    red = (obs[..., 0] > 150) & (obs[..., 1] < 100)
    assert red.any()  # the red car


# -- the supervisor ----------------------------------------------------------------------------


def exhaustive_plan(supervisor: SearchSupervisor, x: float, y: float, h: float) -> np.ndarray:
    """Every sequence scored by the same cost; the first of the minima in search order."""
    best, best_seq = np.inf, None
    for seq in itertools.product(ORDER, repeat=supervisor.depth):
        cost = supervisor.sequence_cost(x, y, h, np.array(seq))
        if cost < best:
            best, best_seq = cost, seq
    return np.array(best_seq)


@pytest.mark.parametrize("depth", [1, 2, 3, 4])
def test_branch_and_bound_returns_the_exhaustive_searchs_first_action(depth: int) -> None:
    rng = np.random.default_rng(depth)
    track = generate_track(np.random.default_rng(depth), CONFIG)
    supervisor = SearchSupervisor(track, CONFIG, depth)
    for _ in range(60):
        x, y, h = track.point_at(rng.uniform(0, track.perimeter))
        x += rng.uniform(-14, 14)
        y += rng.uniform(-14, 14)
        h += rng.uniform(-0.8, 0.8)
        expected = exhaustive_plan(supervisor, x, y, h)
        plan = supervisor.plan(x, y, h)
        assert supervisor.sequence_cost(x, y, h, plan) == supervisor.sequence_cost(
            x, y, h, expected
        )
        assert plan[0] == expected[0]
        # a bound from any real sequence never changes the answer
        bound = supervisor.sequence_cost(x, y, h, rng.integers(0, 3, depth))
        np.testing.assert_array_equal(supervisor.plan(x, y, h, bound), plan)


def drive(env_id: str, tracks: int, **kwargs) -> float:
    """Crashes per lap of the supervisor driving two laps on each of ``tracks`` tracks."""
    crashes = laps = 0.0
    for seed in range(tracks):
        env = gym.make(env_id, obs_type="state", track_seed=seed, **kwargs)
        _, info = env.reset(seed=seed)
        done = False
        while not done:
            _, _, terminated, truncated, info = env.step(info[SUPERVISOR_ACTION_KEY])
            done = terminated or truncated
        crashes += info["crashes"]
        laps += info["laps"]
    return crashes / laps


def test_default_supervisor_rarely_crashes_and_the_source_like_one_often() -> None:
    assert drive("DrivingTrack-v0", 6) <= 0.5
    assert drive("DrivingTrack-Source-v0", 6) >= 1.5


@pytest.mark.slow
def test_crash_rate_falls_with_depth() -> None:
    rates = [drive("DrivingTrack-v0", 8, depth=d) for d in (1, 3, 8)]
    assert rates[0] > rates[1] > rates[2]


def test_labels_are_pure_functions_of_the_state() -> None:
    env = DrivingTrackEnv(obs_type="state", track_seed=4)
    _, info = env.reset(seed=1)
    path = [STRAIGHT, LEFT, LEFT, STRAIGHT, RIGHT, STRAIGHT, STRAIGHT]
    for a in path:
        _, _, _, _, info = env.step(a)
    car = env.sim.car
    pose = (car.x, car.y, car.heading)
    label = env.supervisor_action()
    assert label == info[SUPERVISOR_ACTION_KEY] == env.supervisor_action()  # repeated call
    # the same state reached by another history: a fresh supervisor (no cache, no plan tail),
    # and the same env after labelling other states in between
    fresh = SearchSupervisor(env.track, env.config, env.depth)
    assert fresh.action(*pose) == label
    for other in range(20):
        env.supervisor.action(pose[0] + other, pose[1], pose[2])
    assert env.supervisor.action(*pose) == label
    # the same episode replayed in a second env gives the same labels
    env2 = DrivingTrackEnv(obs_type="state", track_seed=4)
    _, info2 = env2.reset(seed=1)
    for a in path:
        _, _, _, _, info2 = env2.step(a)
    assert info2[SUPERVISOR_ACTION_KEY] == label


# -- the Gymnasium contract --------------------------------------------------------------------


@pytest.mark.parametrize("obs_type", ["hog", "pixels", "state", ["state", "pixels"]])
def test_check_env_passes_with_warnings_as_errors(obs_type) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make("DrivingTrack-v0", obs_type=obs_type, render_mode="rgb_array").unwrapped)


def episode(env: gym.Env, seed: int, actions) -> list:
    obs, info = env.reset(seed=seed)
    out = [(obs.tobytes(), int(info[SUPERVISOR_ACTION_KEY]))]
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(np.int64(a))
        out.append(
            (
                obs.tobytes(),
                reward,
                terminated,
                truncated,
                info["crashes"],
                int(info[SUPERVISOR_ACTION_KEY]),
            )
        )
    return out


def test_same_seed_same_episode_other_seed_other_episode() -> None:
    actions = np.random.default_rng(0).integers(0, 3, 80)
    runs = [episode(gym.make("DrivingTrack-v0"), 5, actions) for _ in range(2)]
    assert runs[0] == runs[1]
    assert episode(gym.make("DrivingTrack-v0"), 6, actions) != runs[0]


def test_pickle_round_trip_mid_episode() -> None:
    env = gym.make("DrivingTrack-v0", track_seed=2)
    env.reset(seed=0)
    for a in (1, 2, 2, 0):
        env.step(a)
    clone = pickle.loads(pickle.dumps(env))
    for a in (1, 1, 0, 2, 1, 1):
        a_out, b_out = env.step(a), clone.step(a)
        assert a_out[0].tobytes() == b_out[0].tobytes()
        assert a_out[1:4] == b_out[1:4]
        assert a_out[4] == b_out[4]


def test_supervisor_contract_and_no_aliasing() -> None:
    env = gym.make("DrivingTrack-Source-v0", obs_type=["hog", "pixels", "state"])
    obs, info = env.reset(seed=3)
    for _ in range(30):
        label = info[SUPERVISOR_ACTION_KEY]
        assert env.action_space.contains(label)
        assert label == env.unwrapped.supervisor_action() == env.unwrapped.supervisor_action()
        kept = {k: v.copy() for k, v in obs.items()}
        obs2, _, _, _, info = env.step(label)
        for k in kept:
            np.testing.assert_array_equal(obs[k], kept[k])  # the step did not write into it
        obs = obs2


def test_episode_ends_after_two_laps_and_reports_laps_and_crashes() -> None:
    env = gym.make("DrivingTrack-v0", obs_type="state", track_seed=0)
    _, info = env.reset(seed=0)
    steps, rewards, done = 0, 0.0, False
    while not done:
        _, reward, terminated, truncated, info = env.step(info[SUPERVISOR_ACTION_KEY])
        rewards += reward
        steps += 1
        done = terminated or truncated
    assert terminated and not truncated
    assert 2.0 <= info["laps"] < 2.2
    assert rewards == -info["crashes"]
    assert isinstance(info["is_success"], bool)


def test_bad_arguments_raise_value_errors_naming_them() -> None:
    with pytest.raises(ValueError, match="depth"):
        DrivingTrackEnv(depth=0)
    with pytest.raises(ValueError, match="obs_type"):
        DrivingTrackEnv(obs_type="lidar")
    with pytest.raises(ValueError, match="obs_type"):
        DrivingTrackEnv(obs_type=["state", "state"])
    with pytest.raises(ValueError, match="half_width"):
        DrivingTrackEnv(half_width=-1.0)
    with pytest.raises(ValueError, match="'dept'"):
        DrivingTrackEnv(dept=3)
    with pytest.raises(ValueError, match="action"):
        DrivingTrackEnv(obs_type="state").step(3)
    assert DrivingTrackEnv(obs_type="state", depth=np.int64(3), speed=np.float64(8.0)).depth == 3
