"""The supervisor contract's snapshot half, on every registered Gymnasium id (issue #27).

For a random learner and for a noisy supervisor, at every step of a short rollout: take
``fluids_bench.core.snapshot.snapshot(env)`` (``env.unwrapped.snapshot()`` plus ``TimeLimit``'s
count), pickle it, restore it into another env made with ``gym.make`` of the same id and reset
with another seed, and check that its ``supervisor_action()`` equals the label of the env that
drove there and that the next steps under the same actions return exactly the same
observations, rewards, terminated/truncated flags and infos. Taking snapshots must not change
the episode, and a snapshot refuses an env of another id or kwargs.
"""

from __future__ import annotations

import pickle

import gymnasium as gym
import numpy as np
import pytest
from exact_compare import exactly_equal

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core import snapshot as snap
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY, RestorableEnv
from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS, make_parallel_env

GYM_IDS = sorted(ENV_SPECS)
SEED = 5
STEPS = 12  # snapshot points per rollout (one per step)
AHEAD = 2  # steps compared after each restore
NOISE = 0.3  # noisy supervisor: Gaussian std as a fraction of the Box's half-range
# more snapshot points where the telling states come late: Singulation's supervisor pushes
# (where pymunk's contact state and the push plan matter) in the last steps of its ~15-20-step
# episodes, so cover a few episodes
STEPS_FOR = {"Singulation-v0": 45}


def _driver(env: gym.Env, kind: str, rng: np.random.Generator):
    """The learner: seeded random actions, or the supervisor's label with noise."""
    space = env.action_space

    def act(info: dict):
        if kind == "random":
            return space.sample()
        label = info[SUPERVISOR_ACTION_KEY]
        if isinstance(space, gym.spaces.Discrete):
            return label if rng.random() < 0.7 else space.sample()
        low, high = space.low.astype(np.float64), space.high.astype(np.float64)
        noisy = label + NOISE * (high - low) / 2 * rng.standard_normal(space.shape)
        return np.clip(noisy, low, high).astype(space.dtype)

    return act


def _run(env_id: str, kind: str, *, check: bool) -> list:
    """A seeded rollout (all it returns); with ``check``, the snapshot contract at every step:
    each snapshot is restored into another env, which then takes the driving env's next
    ``AHEAD`` actions alongside it."""
    env = gym.make(env_id)
    env.action_space.seed(SEED)
    act = _driver(env, kind, np.random.default_rng(SEED))
    targets = [gym.make(env_id) for _ in range(AHEAD)] if check else []
    active: list[list] = []  # [restored env, steps left to compare, snapshot step]
    episode = 0
    obs, info = env.reset(seed=SEED)
    out = [(obs, info)]
    for k in range(STEPS_FOR.get(env_id, STEPS)):
        action = act(info)
        if check:
            saved = pickle.loads(pickle.dumps(snap.snapshot(env)))
            target = targets[k % AHEAD]  # free again: its last comparison window is over
            target.reset(seed=1000 + k)  # another episode, then overwritten
            snap.restore(target, saved)
            label = target.unwrapped.supervisor_action()
            assert exactly_equal(label, info[SUPERVISOR_ACTION_KEY]), (
                f"{env_id} ({kind}, step {k}): restored label {label!r} != the label of the env "
                f"that drove there {info[SUPERVISOR_ACTION_KEY]!r}"
            )
            active.append([target, AHEAD, k])
        step = env.step(action)
        out.append(step)
        for entry in active:
            theirs = entry[0].step(action)
            assert exactly_equal(list(step), list(theirs)), (
                f"{env_id} ({kind}): step {AHEAD - entry[1]} after restoring the snapshot of "
                f"step {entry[2]} differs from the env that drove there"
            )
            entry[1] -= 1
        info = step[4]
        if step[2] or step[3]:
            active = []
            episode += 1
            obs, info = env.reset(seed=SEED + episode)
            out.append((obs, info))
        active = [entry for entry in active if entry[1] > 0]
    env.close()
    return out


@pytest.mark.parametrize("kind", ["random", "noisy"])
@pytest.mark.parametrize("env_id", GYM_IDS)
def test_snapshot_restore_continues_exactly_with_the_same_labels(env_id, kind):
    checked = _run(env_id, kind, check=True)
    assert exactly_equal(checked, _run(env_id, kind, check=False)), (
        f"{env_id} ({kind}): taking snapshots changed the episode"
    )


@pytest.mark.parametrize("env_id", GYM_IDS)
def test_snapshot_is_declared_and_refuses_other_envs(env_id):
    env = gym.make(env_id)
    assert isinstance(env.unwrapped, RestorableEnv)
    env.reset(seed=SEED)
    saved = env.unwrapped.snapshot()
    assert saved.env_id == env_id
    with pytest.raises(TypeError, match="EnvSnapshot"):
        env.unwrapped.restore({"state": b""})
    others = [i for i in GYM_IDS if i != env_id]
    # another id: another class, or the same class with other kwargs
    for other_id in others[:1] + [i for i in others if ENV_SPECS[i][0] == ENV_SPECS[env_id][0]]:
        other = gym.make(other_id)
        with pytest.raises(ValueError, match="restore"):
            other.unwrapped.restore(saved)


def test_snapshot_refuses_other_kwargs_and_accepts_another_render_mode():
    env = gym.make("GridWorld-v0")
    env.reset(seed=SEED)
    saved = env.unwrapped.snapshot()
    with pytest.raises(ValueError, match="slip_probability"):
        gym.make("GridWorld-v0", slip_probability=0.5).unwrapped.restore(saved)
    drawn = gym.make("GridWorld-v0", render_mode="rgb_array")
    drawn.unwrapped.restore(saved)
    assert exactly_equal(drawn.unwrapped.supervisor_action(), env.unwrapped.supervisor_action())
    # an env built directly (no gym.make, no id) with the same kwargs accepts it too
    direct = type(env.unwrapped)()
    direct.restore(saved)
    assert exactly_equal(direct.step(1), env.unwrapped.step(1))


def test_wrapped_restore_carries_the_time_limit():
    env, other = gym.make("GridWorld-v0"), gym.make("GridWorld-v0")
    env.reset(seed=SEED)
    for _ in range(29):  # one step before the 30-step limit
        env.step(0)
    saved = snap.snapshot(env)
    other.reset(seed=SEED + 1)
    snap.restore(other, saved)
    assert other.step(0)[3] and env.step(0)[3]


@pytest.mark.parametrize("env_id", sorted(PARALLEL_ENV_SPECS))
def test_parallel_snapshot_restore_continues_exactly(env_id):
    env, target = make_parallel_env(env_id), make_parallel_env(env_id)
    _, infos = env.reset(seed=SEED)
    for agent in env.possible_agents:
        env.action_space(agent).seed(SEED)
    for k in range(STEPS):
        saved = pickle.loads(pickle.dumps(env.snapshot()))
        target.reset(seed=1000 + k)
        target.restore(saved)
        for agent in env.agents:
            assert exactly_equal(
                target.supervisor_action(agent), infos[agent][SUPERVISOR_ACTION_KEY]
            ), (env_id, k, agent)
        actions = {a: env.action_space(a).sample() for a in env.agents}
        ours = env.step(actions)
        assert exactly_equal(list(ours), list(target.step(actions))), (env_id, k)
        infos = ours[4]
        if not env.agents:
            _, infos = env.reset(seed=SEED + k)
