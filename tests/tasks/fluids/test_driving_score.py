"""The driving score (FLUIDS-v4): its rule by hand, its info keys on every face, Markov labels."""

from __future__ import annotations

import math
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest

import fluids_bench  # noqa: F401
from fluids_bench.registration import make_parallel_env
from fluids_bench.tasks.fluids import driving_score as scoring
from fluids_bench.tasks.fluids.core import labels
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor

KEYS = set(scoring.INFO_KEYS)


@pytest.mark.parametrize(
    ("completion", "infractions", "expected"),
    [
        (1.0, {}, 1.0),
        (0.5, {}, 0.5),
        (1.0, {"pedestrian_collisions": 1}, 0.5),
        (0.8, {"vehicle_collisions": 1}, 0.8 * 0.6),
        (0.3, {"offroad": 1}, 0.3 * 0.65),
        (1.0, {"red_lights": 1, "failures_to_yield": 1}, 0.7 * 0.7),
        (0.4, {"timeouts": 1, "red_lights": 2}, 0.4 * 0.7 * 0.7 * 0.7),
        (1.0, dict.fromkeys(scoring.INFRACTIONS, 0), 1.0),
        (0.0, {"vehicle_collisions": 1}, 0.0),
    ],
)
def test_rule_by_hand(completion, infractions, expected):
    assert math.isclose(scoring.driving_score(completion, infractions), expected, rel_tol=1e-12)


@pytest.mark.parametrize(
    ("completion", "infractions", "match"),
    [
        (1.5, {}, "route_completion"),
        (-0.1, {}, "route_completion"),
        (1.0, {"speeding": 1}, "speeding"),
        (1.0, {"red_lights": -1}, "red_lights"),
        (1.0, {"red_lights": 0.5}, "red_lights"),
    ],
)
def test_rule_refuses_bad_input(completion, infractions, match):
    with pytest.raises(ValueError, match=match):
        scoring.driving_score(completion, infractions)


def test_counts_by_hand():
    """Collisions from the last step's events (the agent's only), lights and yields from the
    fault tracker, the timeout as given."""
    event = SimpleNamespace
    events = [event(a=0, b=3, kind="car-car"), event(a=2, b=5, kind="car-pedestrian")]
    faults = SimpleNamespace(ran_red=np.array([True, False]), failed_to_yield=np.array([0, 1]))
    counts = scoring.count_infractions(faults, 0, events, timed_out=False)
    assert counts == {
        "pedestrian_collisions": 0,
        "vehicle_collisions": 1,
        "offroad": 0,
        "red_lights": 1,
        "failures_to_yield": 0,
        "timeouts": 0,
    }
    # a 100 m route started 20 m in (80 m to cover), followed since a recovery on a 70 m path
    # (its bridge, then the route's end) that starts 30 m into the route's coordinates; 20 m
    # along it the car is 50 m into the route: 30 of 80 m covered
    world = SimpleNamespace(
        reached=np.array([False]), path_len=np.array([70.0]), s=np.array([20.0]),
        offset=np.array([30.0]),
    )  # fmt: skip
    report = scoring.episode_report(world, faults, 0, 80.0, events, timed_out=False)
    assert math.isclose(report["route_completion"], 1.0 - 50.0 / 80.0)
    assert math.isclose(report["driving_score"], (1.0 - 50.0 / 80.0) * 0.6 * 0.7)


def _check(info):
    assert KEYS <= set(info)
    assert 0.0 <= info["driving_score"] <= 1.0
    assert 0.0 <= info["route_completion"] <= 1.0
    assert set(info["infractions"]) == set(scoring.INFRACTIONS)
    expected = scoring.driving_score(info["route_completion"], info["infractions"])
    assert info["driving_score"] == expected


def test_scalar_env_reports_at_every_end():
    """Terminated (random actions leave the road) and timed out (a short limit): the score is
    in the last info only."""
    env = gym.make("FLUIDS-v4")
    env.action_space.seed(1)
    _, info = env.reset(seed=3)
    assert not KEYS & set(info)
    while True:
        _, _, terminated, truncated, info = env.step(env.action_space.sample())
        if terminated or truncated:
            break
        assert not KEYS & set(info)
    _check(info)
    env = gym.make("FLUIDS-v4", max_episode_steps=15, time_limit=15)
    _, info = env.reset(seed=4)
    for _ in range(15):
        _, _, terminated, truncated, info = env.step(info["supervisor_action"])
    assert truncated and not terminated
    _check(info)
    assert info["infractions"]["timeouts"] == 1
    assert 0.0 < info["route_completion"] < 1.0
    assert info["driving_score"] == pytest.approx(0.7 * info["route_completion"])


def test_route_completion_after_a_recovery_path():
    """Pushed off its route (waypoints 4 m to the left for 20 steps), the ego follows a
    recovery path (a Dubins bridge, then the rest of its route) and arrives. Along that path
    the completion is still the share of the route covered from where the car started: the
    metres left are the path's length less the progress along the path (both in the path's
    coordinates), not less the progress in the route's (which counted the path's offset into
    the route as covered twice)."""
    env = gym.make("FLUIDS-v4")
    _, info = env.reset(seed=1)
    inner = env.unwrapped
    world = inner.world
    start, length = float(world.s[0]), float(inner._route_length)
    recovering = 0
    for t in range(600):
        action = info["supervisor_action"].copy()
        if 10 <= t < 30:
            action[1::2] += 0.08  # every waypoint 4 m further left
        _, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
        if world.recovering[0]:
            recovering += 1
            covered = float(world.s[0] + world.offset[0]) - start
            expected = min(max(covered / length, 0.0), 1.0)
            # to within the bridge's resampling (< 1 m of the route; the old rule was ~14 m off)
            got = scoring.route_completion(world, 0, length)
            assert got == pytest.approx(expected, abs=1.0 / length)
    assert recovering > 100  # the check ran along the recovery path
    assert info["is_success"] and info["route_completion"] == 1.0


def test_older_ids_report_no_score():
    env = gym.make("FLUIDS-v3", max_episode_steps=5)
    _, info = env.reset(seed=0)
    for _ in range(5):
        _, _, terminated, truncated, info = env.step(info["supervisor_action"])
    assert truncated and not KEYS & set(info)


def test_vector_env_reports_as_the_scalar_env():
    """Same seeds and actions: each world's last info carries the scalar env's entries."""
    n, limit = 3, 40
    vec = gym.make_vec(
        "FLUIDS-v4", n, vectorization_mode="vector_entry_point",
        max_episode_steps=limit, time_limit=limit,
    )  # fmt: skip
    scalars = [gym.make("FLUIDS-v4", max_episode_steps=limit, time_limit=limit) for _ in range(n)]
    rng = np.random.default_rng(0)
    vec.reset(seed=10)
    for i, env in enumerate(scalars):
        env.reset(seed=10 + i)
    done: set[int] = set()
    for _ in range(limit):
        actions = rng.uniform(-0.2, 0.2, (n, *vec.single_action_space.shape)).astype(np.float32)
        _, _, term, trunc, info = vec.step(actions)
        for i, env in enumerate(scalars):
            if i in done:  # (the vector env autoresets it)
                continue
            _, _, t, u, single = env.step(actions[i])
            assert (t, u) == (term[i], trunc[i])
            if t or u:
                done.add(i)
                assert info["_driving_score"][i]
                assert info["driving_score"][i] == single["driving_score"]
                assert info["route_completion"][i] == single["route_completion"]
                for key, count in single["infractions"].items():
                    assert info["infractions"][key][i] == count
            else:
                assert not info.get("_driving_score", np.zeros(n, bool))[i]
        if len(done) == n:
            break
    assert len(done) == n


def test_multi_agent_env_reports_per_agent():
    env = make_parallel_env("FLUIDS-MultiAgent-v4", max_cycles=30)
    _, infos = env.reset(seed=2)
    ended = set()
    while env.agents:
        actions = {a: env.action_space(a).sample() for a in env.agents}
        _, _, terms, truncs, infos = env.step(actions)
        for agent in terms:
            if terms[agent] or truncs[agent]:
                _check(infos[agent])
                assert infos[agent]["infractions"]["timeouts"] == int(truncs[agent])
                ended.add(agent)
            else:
                assert not KEYS & set(infos[agent])
    assert ended == set(env.possible_agents)


def _fresh_label(env):
    """What a supervisor constructed anew on (a copy of) the current world labels."""
    import copy

    inner = env.unwrapped
    world = copy.deepcopy(inner.world)
    fresh = DrivingSupervisor(world, inner.supervisor_config)
    fresh.prepare(world)
    return labels.label(fresh, world, inner.action_level, 0, inner.action_scale)


@pytest.mark.parametrize("driver", ["random", "noisy"])
def test_labels_equal_a_fresh_supervisors(driver):
    """On FLUIDS-v4 the ego's label is a function of the state: a supervisor built afresh from
    it gives the same label (not a restored one, which would carry the plan)."""
    env = gym.make("FLUIDS-v4")
    env.action_space.seed(5)
    rng = np.random.default_rng(5)
    _, info = env.reset(seed=21)
    episode = 0
    for _ in range(60):
        assert np.array_equal(_fresh_label(env), info["supervisor_action"])
        if driver == "random":
            action = env.action_space.sample()
        else:
            action = np.clip(
                info["supervisor_action"] + 0.1 * rng.standard_normal(env.action_space.shape),
                -1, 1,
            ).astype(np.float32)  # fmt: skip
        _, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            episode += 1
            _, info = env.reset(seed=21 + episode)


def test_multi_agent_labels_equal_a_fresh_supervisors():
    """FLUIDS-MultiAgent-v4: every live agent's label is a fresh supervisor's."""
    import copy

    env = make_parallel_env("FLUIDS-MultiAgent-v4", max_cycles=40)
    _, infos = env.reset(seed=8)
    rng = np.random.default_rng(8)
    checked = 0
    while env.agents:
        world = copy.deepcopy(env.world)
        fresh = DrivingSupervisor(world, env.supervisor_config)
        fresh.prepare(world)
        for agent in env.agents:
            i = int(agent.split("_")[1])
            label = labels.label(fresh, world, env.action_level, i, env.action_scale)
            assert np.array_equal(label, infos[agent]["supervisor_action"]), agent
            checked += 1
        actions = {
            a: np.clip(
                infos[a]["supervisor_action"] + 0.1 * rng.standard_normal(2 * 5), -1, 1
            ).astype(np.float32)
            for a in env.agents
        }
        _, _, _, _, infos = env.step(actions)
    assert checked > 40
