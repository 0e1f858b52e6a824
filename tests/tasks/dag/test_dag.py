"""DAG-v0: API conformance, the DAG's dynamics and supervisor, and Theorem 1's two behaviours."""

from __future__ import annotations

import pickle

import gymnasium as gym
import numpy as np
import pytest

import fluids_bench  # noqa: F401
from fluids_bench.algos.actors import SUPERVISOR
from fluids_bench.algos.bc import BCConfig
from fluids_bench.algos.bc import run as run_bc
from fluids_bench.algos.dagger import DAggerConfig
from fluids_bench.algos.dagger import run as run_dagger
from fluids_bench.algos.policies import PolicySpec
from fluids_bench.algos.rollout import rollout
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.tasks.dag import draw
from fluids_bench.tasks.dag.env import DAGEnv
from fluids_bench.tasks.dag.model import L, R
from fluids_bench.tasks.dag.supervisor import expected_return, greedy_action

CONSTANT = PolicySpec("constant")
ROOT = np.zeros(2, dtype=np.float32)
# the constant class {L, R} on the DAG, evaluated only at the end
THEOREM = {"env_id": "DAG-v0", "policy": CONSTANT, "eval_episodes": 1, "eval_at": ()}


def test_same_seed_same_episode_and_pickle_round_trip() -> None:
    def run(env: gym.Env, seed: int) -> list:
        obs, _ = env.reset(seed=seed)
        out = [obs.tobytes()]
        for a in (L, R, R):
            obs, reward, terminated, truncated, info = env.step(np.int64(a))
            out.append(
                (obs.tobytes(), reward, terminated, truncated, int(info[SUPERVISOR_ACTION_KEY]))
            )
        return out

    a, b = gym.make("DAG-v0"), gym.make("DAG-v0")
    assert [run(a, s) for s in range(20)] == [run(b, s) for s in range(20)]
    env = gym.make("DAG-v0", mu=0.5)
    env.reset(seed=1)
    env.step(np.int64(L))
    clone = pickle.loads(pickle.dumps(env))
    for action in (R, L):
        (obs_a, reward_a, *_), (obs_b, reward_b, *_) = env.step(action), clone.step(action)
        assert obs_a.tobytes() == obs_b.tobytes() and reward_a == reward_b


def test_episode_is_three_decisions_from_the_root() -> None:
    env = DAGEnv()
    obs, info = env.reset(seed=0)
    np.testing.assert_array_equal(obs, ROOT)
    assert info[SUPERVISOR_ACTION_KEY] == L
    flags = [env.step(np.int64(R))[2] for _ in range(3)]
    assert flags == [False, False, True]
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.int64(R))


def test_only_L_at_the_root_slips_with_probability_mu() -> None:
    env = DAGEnv(mu=0.25)
    slips = 0
    for seed in range(4000):
        env.reset(seed=seed)
        slips += int(env.step(np.int64(L))[0][1])  # index 1 = reached the right child
    assert abs(slips / 4000 - 0.25) < 0.025
    for seed in range(50):
        env.reset(seed=seed)
        assert env.step(np.int64(R))[0][1] == 1
        assert env.step(np.int64(L))[0][1] == 1  # below the root moves are exact


def test_supervisor_labels_match_the_proof() -> None:
    # root L; left subtree L, L; right subtree R, R (demonstrations read LLL or LRR)
    assert [greedy_action(0, 0), greedy_action(1, 0), greedy_action(1, 1)] == [L, L, R]
    assert [greedy_action(2, 0), greedy_action(2, 1), greedy_action(2, 2)] == [L, R, R]
    env = gym.make("DAG-v0", mu=0.25)
    sequences = {tuple(rollout(env, SUPERVISOR, s).labels.tolist()) for s in range(40)}
    assert sequences == {(L, L, L), (L, R, R)}


def test_monte_carlo_returns_match_the_exact_expected_returns() -> None:
    mu = 0.25
    assert expected_return(mu, "supervisor") == pytest.approx(6 - 4 * mu)
    assert expected_return(mu, "L") == pytest.approx(6 - 6 * mu)
    assert expected_return(mu, "R") == pytest.approx(2.0)
    env = gym.make("DAG-v0", mu=mu)
    mean = np.mean([rollout(env, SUPERVISOR, s).total_return for s in range(3000)])
    assert abs(mean - expected_return(mu, "supervisor")) < 0.15


@pytest.mark.parametrize(("value"), [-0.1, 1.5, float("inf"), "0.2"])
def test_bad_mu_names_field_and_range(value: object) -> None:
    with pytest.raises(ValueError, match=r"field 'mu' is .*allowed"):
        DAGEnv(mu=value)


def test_off_policy_converges_to_L() -> None:
    for seed in range(5):
        assert run_bc(BCConfig(**THEOREM, iterations=60, seed=seed)).policy.act(ROOT) == L


def test_on_policy_keeps_R_forever_once_its_first_vote_says_R() -> None:
    # m = 1: a slipped initial demonstration (L R R) makes R the majority; every R rollout
    # adds L R R again, so DAgger (beta = 0) never leaves R. Otherwise it starts at L.
    slipped_runs = 0
    for seed in range(40):
        result = run_dagger(DAggerConfig(**THEOREM, initial_demos=1, iterations=15, seed=seed))
        initial_return = result.records[0].collection_return  # 2.0 = the slipped path L R R
        if initial_return == 2.0:
            slipped_runs += 1
            assert result.policy.act(ROOT) == R
            assert all(r.collection_return == 2.0 for r in result.records[1:])
        else:
            assert initial_return == 6.0
    assert 0 < slipped_runs < 40


def test_unknown_kwargs_and_numpy_scalars() -> None:
    with pytest.raises(
        ValueError, match=r"unknown argument\(s\) 'nu'; allowed: \['mu', 'render_mode'\]"
    ):
        gym.make("DAG-v0", nu=0.3)
    assert gym.make("DAG-v0", mu=np.float32(0.5)).unwrapped.mu == 0.5


def test_rgb_array_shows_the_robot_and_the_edge_it_took():
    env = gym.make("DAG-v0", render_mode="rgb_array", mu=0.0)
    env.reset(seed=0)
    root = env.render()
    assert root.shape == (draw.SIZE, draw.SIZE, 3) and root.dtype == np.uint8
    assert tuple(root[draw.node_centre(0, 0)[::-1]]) == draw.ROBOT
    env.step(R)
    env.step(L)  # (0, 0) -R-> (1, 1) -L-> (2, 1)
    frame = env.render()
    x, y = draw.node_centre(2, 1)
    assert tuple(frame[y, x]) == draw.ROBOT
    assert tuple(frame[draw.node_centre(1, 1)[::-1]]) == draw.BACKGROUND
    (ax, ay), (bx, by) = draw.node_centre(1, 1), draw.node_centre(2, 1)
    assert tuple(frame[(ay + by) // 2, (ax + bx) // 2]) == draw.TAKEN  # the L edge just taken
    (cx, cy), (dx, dy) = draw.node_centre(0, 0), draw.node_centre(1, 1)
    assert tuple(frame[(cy + dy) // 2, (cx + dx) // 2]) != draw.TAKEN  # only the last edge


def test_render_without_a_mode_returns_none():
    env = gym.make("DAG-v0")
    env.reset(seed=0)
    assert env.unwrapped.render() is None
