"""FLUIDS-v0 through the Gymnasium API: checker, determinism, pickling, errors, bot test."""

from __future__ import annotations

import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from exact_compare import exactly_equal
from gymnasium.utils.env_checker import check_env

import fluids_bench  # noqa: F401  (registers the ids)

LEVELS = ("behavior", "trajectory", "velocity", "control")
# reviewed allow-list: the velocity (m/s) and trajectory (m) levels keep physical units
ALLOWED_WARNINGS = (".*symmetric and normalized.*",)


def _check(env: gym.Env) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for pattern in ALLOWED_WARNINGS:
            warnings.filterwarnings("ignore", message=pattern)
        check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("level", LEVELS)
def test_check_env_every_level(level):
    _check(gym.make("FLUIDS-v0", action_level=level))


def _perturb(env, info, rng, k):
    """The supervisor's label, perturbed on some steps so the episode leaves the nominal path."""
    a = info["supervisor_action"]
    if k % 7 != 3:
        return a
    if isinstance(a, int):
        return int(rng.integers(env.action_space.n))
    return np.clip(
        a + rng.normal(0, 0.3, a.shape), env.action_space.low, env.action_space.high
    ).astype(np.float32)


def _rollout(level: str, seed: int, steps: int, **kwargs):
    env = gym.make("FLUIDS-v0", action_level=level, **kwargs)
    rng = np.random.default_rng(seed)
    obs, info = env.reset(seed=seed)
    trace = [(obs, info)]
    for k in range(steps):
        obs, r, term, trunc, info = env.step(_perturb(env, info, rng, k))
        trace.append((obs, r, term, trunc, info))
        if term or trunc:
            break
    return trace


@pytest.mark.parametrize("level", LEVELS)
def test_same_seed_same_episode(level):
    kw = {"num_cars": 5, "num_pedestrians": 3, "obs_noise": 0.1}
    a, b = _rollout(level, 7, 120, **kw), _rollout(level, 7, 120, **kw)
    assert exactly_equal(a, b)


def test_different_seeds_give_different_starts():
    env = gym.make("FLUIDS-v0")
    starts = {env.reset(seed=s)[0].tobytes() for s in range(8)}
    assert len(starts) == 8


def test_pickle_round_trip_mid_episode():
    env = gym.make("FLUIDS-v0", num_pedestrians=3)
    _, info = env.reset(seed=11)
    for _ in range(30):
        _, _, _, _, info = env.step(info["supervisor_action"])
    clone = pickle.loads(pickle.dumps(env))
    for _ in range(40):
        a = info["supervisor_action"]
        out1, out2 = env.step(a), clone.step(a)
        assert exactly_equal(list(out1), list(out2))
        info = out1[-1]
        if out1[2] or out1[3]:
            break


def test_label_matches_on_demand_call():
    env = gym.make("FLUIDS-v0", action_level="velocity")
    _, info = env.reset(seed=2)
    for _ in range(25):
        assert np.array_equal(info["supervisor_action"], env.unwrapped.supervisor_action())
        _, _, _, _, info = env.step(info["supervisor_action"])


def test_observation_does_not_alias_the_world():
    env = gym.make("FLUIDS-v0")
    obs, _ = env.reset(seed=0)
    before = env.unwrapped.world.state.copy()
    obs[:] = 123.0
    assert np.array_equal(env.unwrapped.world.state, before)
    obs2, *_ = env.step(env.unwrapped.supervisor_action())
    assert not np.shares_memory(obs, obs2)


@pytest.mark.parametrize("bad", [np.array([np.nan, 0.0]), np.array([0.0, np.inf])])
def test_non_finite_actions_are_refused(bad):
    env = gym.make("FLUIDS-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="not finite"):
        env.step(bad)


def test_out_of_bounds_actions_are_clipped():
    runs = []
    for action in (np.array([5.0, -9.0]), np.array([1.0, -1.0])):
        env = gym.make("FLUIDS-v0")
        env.reset(seed=4)
        runs.append([env.step(action)[0] for _ in range(5)])
    assert all(np.array_equal(x, y) for x, y in zip(*runs, strict=True))


def test_wrong_shape_and_bad_behavior_actions_are_refused():
    env = gym.make("FLUIDS-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(3))
    env = gym.make("FLUIDS-v0", action_level="behavior")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="integer in"):
        env.step(17)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"action_level": "steering"}, "action_level"),
        ({"layout": "cloverleaf"}, "layout"),
        ({"lanes": 3}, "lanes"),
        ({"num_cars": -1}, "num_cars"),
        ({"obs_noise": -0.5}, "obs_noise"),
        ({"dt": 2.0}, "dt"),
        ({"car_mass": 0.0}, "mass"),
        ({"obs_type": "sonar"}, "obs_type"),
    ],
)
def test_bad_kwargs_name_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        gym.make("FLUIDS-v0", **kwargs)


def test_too_many_cars_names_the_capacity():
    # checked at construction, in the user's terms: 15 besides the ego, never "16" or "64"
    with pytest.raises(
        ValueError,
        match=r"'num_cars' is 63; .* at most 16 cars, the ego included: "
        r"allowed: an integer in \[0, 15\]",
    ):
        gym.make("FLUIDS-v0", num_cars=63)
    gym.make("FLUIDS-v0", num_cars=15).reset(seed=0)


@pytest.mark.parametrize("layout", ["four_way", "t_junction", "roundabout"])
def test_supervisor_bot_reaches_the_goal(layout):
    """The ego following its supervisor's labels arrives without collision (MiniGrid bot test)."""
    env = gym.make("FLUIDS-v0", layout=layout, max_episode_steps=1200)
    for seed in range(3):
        _, info = env.reset(seed=seed)
        total = 0.0
        while True:
            _, r, term, trunc, info = env.step(info["supervisor_action"])
            total += r
            if term or trunc:
                break
        assert term and info["is_success"], (layout, seed, info)
        assert total == pytest.approx(1.0, abs=1e-6)


def test_collision_terminates_with_penalty():
    env = gym.make("FLUIDS-v0", num_cars=0, num_pedestrians=0, lights=False)
    env.reset(seed=0)
    for _ in range(200):  # full lock and throttle: the ego leaves the road
        _, r, term, _, info = env.step(np.array([1.0, 1.0], dtype=np.float32))
        if term:
            break
    assert term and not info["is_success"]
    assert any(c["kind"] == "offroad" and c["a"] == 0 for c in info["collisions"])
    assert r < 0


def test_done_when_all_waits_for_every_car():
    env = gym.make("FLUIDS-v0", num_cars=4, done_when="all", max_episode_steps=1500)
    _, info = env.reset(seed=3)
    ego_arrived_at = None
    steps = 0
    while True:
        _, r, term, trunc, info = env.step(info["supervisor_action"])
        steps += 1
        if info["ego_arrived"] and ego_arrived_at is None:
            ego_arrived_at = steps
        elif ego_arrived_at is not None:
            assert r == 0.0
        if term or trunc:
            break
    assert term and info["is_success"]
    assert env.unwrapped.world.reached[env.unwrapped.world.is_car].all()
    assert ego_arrived_at is not None and ego_arrived_at <= steps
