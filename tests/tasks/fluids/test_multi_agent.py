"""FLUIDS as a PettingZoo ParallelEnv: the PettingZoo test suite, capacity, agents leaving."""

from __future__ import annotations

import pickle
import warnings

import numpy as np
import pytest
import shapely
from exact_compare import exactly_equal
from pettingzoo.utils.conversions import parallel_to_aec

from fluids_bench.registration import PARALLEL_ENV_SPECS, make_parallel_env
from fluids_bench.tasks.fluids.multi_agent import FluidsParallelEnv, agent_observers, parallel_env
from fluids_bench.tasks.fluids.sim.sensors.explicit import ExplicitSensor
from fluids_bench.tasks.fluids.supervisor.stack import LEVELS

with warnings.catch_warnings():
    # allow-list: importing pettingzoo.test loads PettingZoo's own example envs (connect
    # four, ...) through their deprecated creation API, which warns; nothing of ours runs here
    warnings.simplefilter("ignore", DeprecationWarning)
    from pettingzoo.test import parallel_api_test, parallel_seed_test
    from pettingzoo.test.state_test import test_parallel_env as check_parallel_state
    from pettingzoo.test.state_test import test_state as check_state
    from pettingzoo.test.state_test import test_state_space as check_state_space

# PettingZoo's checks run with every warning an error: nothing is allowed through
pytestmark = pytest.mark.filterwarnings("error")


def _random_episode(env, seed: int, steps: int) -> list:
    """Seeded random actions for every live agent; everything the env returns, in order."""
    out = [env.reset(seed=seed)]
    for i, agent in enumerate(env.possible_agents):
        env.action_space(agent).seed(seed + i)
    while env.agents and len(out) <= steps:
        out.append(env.step({a: env.action_space(a).sample() for a in env.agents}))
        out.append(env.state())
    return out


@pytest.mark.parametrize("level", LEVELS)
def test_pettingzoo_api_and_seed_tests(level):
    env = parallel_env(controlled_cars=5, num_cars=2, action_level=level)
    parallel_api_test(env, num_cycles=25)  # sets env.max_cycles = 25: episodes end by truncation
    parallel_seed_test(lambda: parallel_env(controlled_cars=3, action_level=level, obs_noise=0.1))


def test_pettingzoo_state_tests():
    env = parallel_env(controlled_cars=3, num_cars=1, max_cycles=15)
    check_state_space(env)
    check_parallel_state(env)
    check_state(parallel_to_aec(parallel_env(controlled_cars=3, max_cycles=15)), num_cycles=15)


def test_random_episodes_are_deterministic_and_seed_dependent():
    make = lambda: parallel_env(controlled_cars=4, num_cars=2, obs_noise=0.05, max_cycles=60)  # noqa: E731
    first, second = _random_episode(make(), 3, 60), _random_episode(make(), 3, 60)
    assert exactly_equal(first, second)
    other = _random_episode(make(), 4, 60)
    assert not exactly_equal(first[0], other[0])


def test_registered_factory_and_pickle_round_trip():
    assert "FLUIDS-MultiAgent-v0" in PARALLEL_ENV_SPECS
    env = make_parallel_env("FLUIDS-MultiAgent-v0", controlled_cars=3, max_cycles=30)
    assert isinstance(env, FluidsParallelEnv)
    _, infos = env.reset(seed=7)
    for _ in range(5):
        _, _, _, _, infos = env.step({a: infos[a]["supervisor_action"] for a in env.agents})
    clone = pickle.loads(pickle.dumps(env))
    for _ in range(5):
        actions = {a: infos[a]["supervisor_action"] for a in env.agents}
        out = env.step(actions)
        assert exactly_equal(out, clone.step(actions))
        infos = out[4]


@pytest.mark.parametrize(
    ("layout", "lanes", "most"),
    [
        ("four_way", 1, 16),
        ("four_way", 2, 32),
        ("t_junction", 1, 12),
        ("roundabout", 1, 16),
    ],
)
def test_capacity_fills_without_overlap_and_names_the_maximum(layout, lanes, most):
    env = parallel_env(
        controlled_cars=most - 2, num_cars=2, layout=layout, lanes=lanes, num_pedestrians=0
    )
    env.reset(seed=1)
    assert len(env.agents) == most - 2
    polys = shapely.polygons(env.world.corners())
    a, b = shapely.STRtree(polys).query(polys, predicate="intersects")
    assert np.all(a == b), "spawned cars overlap"
    with pytest.raises(ValueError, match=f"holds at most {most} cars"):
        parallel_env(controlled_cars=most - 1, num_cars=2, layout=layout, lanes=lanes)
    with pytest.raises(ValueError, match=f"controlled_cars <= {most - 2}"):
        parallel_env(controlled_cars=most, num_cars=2, layout=layout, lanes=lanes)


def test_bad_arguments_and_actions_raise():
    with pytest.raises(ValueError, match="controlled_cars"):
        parallel_env(controlled_cars=0)
    with pytest.raises(ValueError, match="unknown argument"):
        parallel_env(lidar_beams=3)
    with pytest.raises(ValueError, match="action_level"):
        parallel_env(action_level="steer")
    env = parallel_env(controlled_cars=2)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="unknown agents"):
        env.step({"car_9": np.zeros(2, np.float32)})
    with pytest.raises(ValueError, match="not finite"):
        env.step({"car_0": np.array([np.nan, 0.0], np.float32)})
    with pytest.raises(ValueError, match="shape"):
        env.step({"car_0": np.zeros(3, np.float32)})


def test_observations_are_each_agents_own_view():
    env = parallel_env(controlled_cars=3, num_cars=1, k_nearest=4)
    observations, _ = env.reset(seed=2)
    sensor = ExplicitSensor(4)
    rng = np.random.default_rng(0)  # unused: no noise
    for i, agent in enumerate(env.possible_agents):
        assert env.observation_space(agent).contains(observations[agent])
        np.testing.assert_array_equal(observations[agent], sensor.observe(env.world, rng, ego=i))
    assert not np.array_equal(observations["car_0"], observations["car_1"])
    observations["car_0"][:] = 0.0  # observations do not alias the world
    assert env.world.state[0, :2].any()


def test_supervised_agents_all_arrive_with_labels_in_their_spaces():
    env = parallel_env(controlled_cars=4, num_cars=2, num_pedestrians=2, action_level="velocity")
    _, infos = env.reset(seed=5)
    finished = {}
    while env.agents:
        for a in env.agents:
            assert env.action_space(a).contains(infos[a]["supervisor_action"])
            np.testing.assert_array_equal(infos[a]["supervisor_action"], env.supervisor_action(a))
        _, rewards, terms, truncs, infos = env.step(
            {a: infos[a]["supervisor_action"] for a in env.agents}
        )
        finished.update({a: infos[a] for a in terms if terms[a] or truncs[a]})
    assert set(finished) == set(env.possible_agents)
    assert all(info["is_success"] and info["arrived"] for info in finished.values())


def test_a_crashing_agent_leaves_and_the_others_go_on():
    env = parallel_env(controlled_cars=3, num_cars=1, num_pedestrians=0, max_cycles=200)
    _, infos = env.reset(seed=0)
    hard_left = np.array([1.0, 1.0], np.float32)
    for _ in range(200):
        actions = {a: infos[a]["supervisor_action"] for a in env.agents}
        if "car_0" in env.agents:
            actions["car_0"] = hard_left
        _, rewards, terms, truncs, infos = env.step(actions)
        if terms.get("car_0"):
            break
    assert terms["car_0"] and infos["car_0"]["collisions"]
    assert rewards["car_0"] < -0.5 and not infos["car_0"]["is_success"]
    assert "car_0" not in env.agents and env.agents, "the others are still driving"
    assert not env.world.active[0], "the crashed car left the road"
    assert env.state()[5] == 0.0  # car_0's active flag in the global state
    state = env.world.state[0].copy()
    env.step({a: infos[a]["supervisor_action"] for a in env.agents})
    np.testing.assert_array_equal(env.world.state[0], state)


def test_truncation_at_max_cycles_and_background_keeps_moving():
    env = parallel_env(controlled_cars=2, num_cars=2, action_level="velocity", max_cycles=12)
    env.reset(seed=4)
    start = env.world.state.copy()
    for step in range(1, 13):
        _, _, terms, truncs, _ = env.step({a: np.zeros(1, np.float32) for a in env.agents})
        assert all(truncs.values()) == (step == 12) and not any(terms.values())
    assert env.agents == []
    moved = np.hypot(*(env.world.state[:, :2] - start[:, :2]).T)
    assert np.all(moved[:2] < 1e-9), "controlled cars told to stand still moved"
    assert np.any(moved[2:4] > 0.1), "supervised background cars did not move"
    with pytest.raises(RuntimeError, match="reset"):
        env.step({})


def test_missing_action_means_supervised():
    make = lambda: parallel_env(controlled_cars=2, max_cycles=20)  # noqa: E731
    a, b = make(), make()
    _, infos = a.reset(seed=9)
    b.reset(seed=9)
    for _ in range(15):
        labels = {agent: infos[agent]["supervisor_action"] for agent in a.agents}
        infos = a.step(labels)[4]
        b.step({"car_0": labels["car_0"]})  # car_1 left to its supervisor
        # the labels are float32 roundings of the supervisor's controls: equal up to that
        np.testing.assert_allclose(a.world.state, b.world.state, atol=1e-4)


@pytest.mark.parametrize("obs_type", ["qlidar", "birdseye", ["explicit", "qlidar", "birdseye"]])
def test_every_observation_family_observes_per_agent(obs_type):
    env = parallel_env(controlled_cars=3, num_cars=1, obs_type=obs_type, birdseye_size=64)
    parallel_api_test(env, num_cycles=8)
    observations, _ = env.reset(seed=1)
    for agent in env.possible_agents:
        assert env.observation_space(agent).contains(observations[agent])
    first, second = observations["car_0"], observations["car_1"]
    if isinstance(first, dict):
        assert not any(np.array_equal(first[k], second[k]) for k in first)
    else:
        assert not np.array_equal(first, second)


def test_a_family_without_ego_is_refused_for_several_agents():
    class NoEgo:
        space = None

        def observe(self, world, rng):
            return np.zeros(1)

    class Fake:
        parts = {"legacy": NoEgo()}

    observers, ego_only = agent_observers(Fake())
    assert ego_only == ["legacy"] and observers["legacy"](None, None, 0).shape == (1,)


def test_rgb_array_render():
    env = parallel_env(controlled_cars=2, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    with pytest.raises(ValueError, match="render_mode"):
        parallel_env(render_mode="human")


def test_ompl_trajectory_planner():
    env = parallel_env(controlled_cars=2, trajectory_planner="ompl", max_cycles=10)
    parallel_api_test(env, num_cycles=10)
    with pytest.raises(ValueError, match="trajectory_planner"):
        parallel_env(trajectory_planner="rrt")
