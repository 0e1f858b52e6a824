"""Registry-driven tests: every id in ``fluids_bench.registration`` is tested by being registered.

Each Gymnasium id of ``ENV_SPECS`` passes Gymnasium's ``check_env`` with warnings as errors (minus
the reviewed allow-list below), replays exactly from a seed, survives a pickle round trip
mid-episode, and honours the supervisor contract of ``fluids_bench.core.supervisor``. Each
PettingZoo id of ``PARALLEL_ENV_SPECS`` passes PettingZoo's ``parallel_api_test`` and
``parallel_seed_test`` (built through ``pettingzoo.make``) and the per-agent supervisor contract.

Rollouts are driven by actions sampled from a seeded action space (a learner that is not the
supervisor), run ``TEST_STEPS.get(id, DEFAULT_TEST_STEPS)`` steps and reset with the next seed
when an episode ends. An expensive id declares fewer steps in ``registration.TEST_STEPS``.
"""

from __future__ import annotations

import pickle
import re
import warnings

import gymnasium as gym
import numpy as np
import pettingzoo
import pytest
from exact_compare import exactly_equal
from gymnasium.envs.registration import load_env_creator
from gymnasium.utils.env_checker import check_env

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.registration import (
    DEFAULT_TEST_STEPS,
    ENV_SPECS,
    PARALLEL_ENV_SPECS,
    TEST_STEPS,
)

with warnings.catch_warnings():
    # importing pettingzoo.test loads PettingZoo's own example envs through their deprecated
    # creation API, which warns; nothing of ours runs here
    warnings.simplefilter("ignore", DeprecationWarning)
    from pettingzoo.test import parallel_api_test, parallel_seed_test

GYM_IDS = sorted(ENV_SPECS)
PARALLEL_IDS = sorted(PARALLEL_ENV_SPECS)
SEED = 3

# Reviewed allow-list for check_env (every other warning is an error). Keep it short; each entry
# says why the warning is wrong for this suite.
ALLOWED_WARNINGS = (
    # "Box action space ... not symmetric and normalized": Gymnasium's advice for RL learners.
    # An IL action is the supervisor's label in physical units (FLUIDS' velocity level is a
    # target speed in [0, v_max] m/s, its trajectory level waypoints in metres); rescaling it
    # would make every label and dataset unit-less.
    r".*symmetric and normalized.*",
    # "Box observation space minimum/maximum value is -infinity/infinity": Gymnasium's own MuJoCo
    # v5 envs (held unchanged by the locomotion ids) declare unbounded joint velocities and
    # positions; a bound would be made up.
    r".*Box observation space (minimum|maximum) value is -?infinity.*",
)


def _steps(env_id: str) -> int:
    return TEST_STEPS.get(env_id, DEFAULT_TEST_STEPS)


def _renders_rgb(env_id: str) -> bool:
    """Whether the id's env class declares rgb_array rendering (read without building it)."""
    creator = load_env_creator(gym.spec(env_id).entry_point)
    metadata = getattr(creator, "metadata", None)
    if metadata is None:  # a factory function, not a class: ask a built env
        metadata = gym.make(env_id).metadata
    return "rgb_array" in metadata.get("render_modes", [])


def _rollout(env_id: str, steps: int, *, ask_supervisor: bool = False) -> list:
    """Everything a seeded episode returns under seeded sampled actions, in order.

    With ``ask_supervisor``, the supervisor contract is checked in every state visited."""
    env = gym.make(env_id)
    env.action_space.seed(SEED)
    episode = 0
    obs, info = env.reset(seed=SEED)
    out = [(obs, info)]
    for _ in range(steps):
        if ask_supervisor:
            _check_label(env, info)
        step = env.step(env.action_space.sample())
        out.append(step)
        info = step[4]
        if step[2] or step[3]:
            episode += 1
            obs, info = env.reset(seed=SEED + episode)
            out.append((obs, info))
    if ask_supervisor:
        _check_label(env, info)
    env.close()
    return out


def _check_label(env: gym.Env, info: dict) -> None:
    label = info[SUPERVISOR_ACTION_KEY]
    asked = env.unwrapped.supervisor_action()
    assert exactly_equal(label, asked), f"info label {label!r} != supervisor_action() {asked!r}"
    assert env.action_space.contains(label), f"label {label!r} not in {env.action_space}"
    again = env.unwrapped.supervisor_action()
    assert exactly_equal(again, asked), f"second call gave {again!r}, first {asked!r}"


@pytest.mark.parametrize("env_id", GYM_IDS)
def test_check_env_with_warnings_as_errors(env_id):
    render = _renders_rgb(env_id)
    env = gym.make(env_id, render_mode="rgb_array") if render else gym.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for pattern in ALLOWED_WARNINGS:
            warnings.filterwarnings("ignore", message=pattern)
        check_env(env.unwrapped, skip_render_check=not render)


@pytest.mark.parametrize("env_id", GYM_IDS)
def test_seeded_rollouts_are_identical(env_id):
    first, second = _rollout(env_id, _steps(env_id)), _rollout(env_id, _steps(env_id))
    for k, (a, b) in enumerate(zip(first, second, strict=True)):
        assert exactly_equal(a, b), f"{env_id}: the two seeded runs differ at output {k}"


@pytest.mark.parametrize("env_id", GYM_IDS)
def test_pickle_round_trip_mid_episode_continues_identically(env_id):
    steps = _steps(env_id)
    env = gym.make(env_id)
    env.action_space.seed(SEED)
    _, info = env.reset(seed=SEED)
    for _ in range(steps // 2):
        *_, terminated, truncated, info = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset(seed=SEED + 1)
    clone = pickle.loads(pickle.dumps(env))
    assert exactly_equal(clone.unwrapped.supervisor_action(), env.unwrapped.supervisor_action())
    for k in range(steps - steps // 2):
        action = env.action_space.sample()
        a, b = env.step(action), clone.step(action)
        assert exactly_equal(list(a), list(b)), f"{env_id}: the clone differs at step {k}"
        if a[2] or a[3]:
            assert exactly_equal(env.reset(seed=SEED + 2), clone.reset(seed=SEED + 2))


@pytest.mark.parametrize("env_id", GYM_IDS)
def test_supervisor_contract(env_id):
    """In every state visited (a sampled-action learner drives), the info label equals
    ``supervisor_action()``, lies in the action space and a second call gives it again; asking
    does not change the episode."""
    asked = _rollout(env_id, _steps(env_id), ask_supervisor=True)
    assert exactly_equal(asked, _rollout(env_id, _steps(env_id))), (
        f"{env_id}: calling supervisor_action() changed the episode"
    )


def _bad_actions(space: gym.Space) -> list:
    """Actions every env must refuse with a ValueError, never coerce."""
    if isinstance(space, gym.spaces.Discrete):
        n = int(space.n)
        return [
            True,
            np.True_,
            1.0,
            np.float64(1.0),
            np.float32(0.0),
            float("inf"),
            float("-inf"),
            float("nan"),
            1j,
            "1",
            None,
            n,  # one past the end
            -1,
            np.array([0]),  # shape (1,) is not a scalar
            np.array(0.0),
            np.array(True),
        ]
    ok = np.zeros(space.shape)
    bad = []
    for value in (np.nan, np.inf, -np.inf):
        a = ok.copy()
        a.reshape(-1)[0] = value
        bad.append(a)
    return [
        *bad,
        ok.astype(np.complex128),
        ok.astype(bool),
        ok.tolist()[:-1],  # too short
        np.zeros((space.shape[0] + 1,)),  # too long
        ok.reshape(1, -1),  # a batch of one is not an action
        0.0,
        "0",
        np.array(["0"] * space.shape[0]),
        [None] * space.shape[0],
    ]


@pytest.mark.parametrize("env_id", GYM_IDS)
def test_bad_actions_are_refused_naming_the_action_and_the_space(env_id):
    env = gym.make(env_id)
    env.reset(seed=SEED)
    space = env.action_space
    for action in _bad_actions(space):
        with pytest.raises(ValueError, match=r"action") as caught:
            env.step(action)
        assert str(space) in str(caught.value), (action, str(caught.value))
    if isinstance(space, gym.spaces.Discrete):  # numpy integers stay actions
        for action in (np.int64(space.start), np.int32(space.start), np.array(space.start)):
            env.step(action)


@pytest.mark.parametrize("env_id", GYM_IDS)
def test_numpy_integer_seeds_seed_as_python_ints(env_id):
    env = gym.make(env_id)
    assert exactly_equal(env.reset(seed=np.int64(5)), env.reset(seed=5))
    assert exactly_equal(env.reset(seed=np.uint8(5)), env.reset(seed=5))
    for bad in (-1, 1.5, np.float64(5.0), "5"):  # Gymnasium's own check still answers
        with pytest.raises(gym.error.Error, match=re.escape("Seed must be")):
            env.reset(seed=bad)


@pytest.mark.parametrize("env_id", PARALLEL_IDS)
def test_parallel_numpy_integer_seeds_seed_as_python_ints(env_id):
    env = _make_parallel(env_id)
    assert exactly_equal(env.reset(seed=np.int64(5)), env.reset(seed=5))


def _make_parallel(env_id: str):
    return pettingzoo.make("parallel", env_id, max_cycles=_steps(env_id))


@pytest.mark.parametrize("env_id", PARALLEL_IDS)
@pytest.mark.filterwarnings("error")
def test_parallel_api_and_seed_tests(env_id):
    parallel_api_test(_make_parallel(env_id), num_cycles=_steps(env_id))
    parallel_seed_test(lambda: _make_parallel(env_id))


@pytest.mark.parametrize("env_id", PARALLEL_IDS)
def test_parallel_supervisor_contract(env_id):
    env = _make_parallel(env_id)
    _, infos = env.reset(seed=SEED)
    for agent in env.possible_agents:
        env.action_space(agent).seed(SEED)
    while True:
        for agent in env.agents:
            label = infos[agent][SUPERVISOR_ACTION_KEY]
            asked = env.supervisor_action(agent)
            assert exactly_equal(label, asked), (agent, label, asked)
            assert env.action_space(agent).contains(label), (agent, label)
            assert exactly_equal(env.supervisor_action(agent), asked), agent
        if not env.agents:
            break
        *_, infos = env.step({a: env.action_space(a).sample() for a in env.agents})


def test_pettingzoo_make_and_make_parallel_env_build_the_same_env():
    for env_id in PARALLEL_IDS:
        a = pettingzoo.make("parallel", env_id, max_cycles=5)
        b = fluids_bench.registration.make_parallel_env(env_id, max_cycles=5)
        assert type(a) is type(b)
        assert exactly_equal(a.reset(seed=SEED), b.reset(seed=SEED))
