"""The FLUIDS vector env (``vectorization_mode="vector_entry_point"``): world i of the batch is the
scalar env reset with seed s + i, bit for bit, at every action level and through autoresets; the
whole batch is Gymnasium's SyncVectorEnv over the same id; bad input is refused before any world
moves."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from exact_compare import exactly_equal
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core import snapshot as snapshots
from fluids_bench.registration import ENV_SPECS, VECTOR_ENTRY_POINTS
from fluids_bench.tasks.fluids.vector import FluidsVectorEnv

FLUIDS_IDS = [i for i, (entry, _, _) in ENV_SPECS.items() if entry in VECTOR_ENTRY_POINTS]
SMALL = {"num_cars": 2, "num_pedestrians": 1}
LEVELS = ("behavior", "trajectory", "velocity", "control")
# actions that leave the road within the first 20 steps (terminations without long episodes)
CRASH = {
    "control": np.array([1.0, 1.0], np.float32),  # full left lock, full throttle
    "trajectory": np.tile(np.array([3.0, -8.0], np.float32), 5),  # every waypoint hard right
}


def make_vec(env_id: str, n: int, **kwargs) -> FluidsVectorEnv:
    return gym.make_vec(env_id, n, vectorization_mode="vector_entry_point", **kwargs)


def same(a, b) -> bool:
    """``exactly_equal``, also element by element inside object arrays (``final_obs``)."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, np.ndarray) and a.dtype == object:
        return (
            isinstance(b, np.ndarray)
            and b.dtype == object
            and a.shape == b.shape
            and all(same(x, y) for x, y in zip(a.ravel(), b.ravel(), strict=True))
        )
    if isinstance(a, tuple):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    return exactly_equal(a, b)


def batched(infos: list[dict]) -> dict:
    """The scalar envs' infos batched by Gymnasium's own ``VectorEnv._add_info``."""
    ref = VectorEnv()
    ref.num_envs = len(infos)
    out: dict = {}
    for i, info in enumerate(infos):
        out = ref._add_info(out, info, i)
    return out


def actions_for(level: str, space, labels, rng: np.random.Generator, t: int) -> np.ndarray:
    """World 0 crashes where the level can steer; the others alternate the supervisor's label
    and a random action (so states the supervisor would not visit are labelled too)."""
    n = len(labels)
    out = np.array(labels, copy=True)
    for i in range(1, n):
        if (t + i) % 3 == 0:
            out[i] = space.sample() if level != "behavior" else rng.integers(space.n)
    if level in CRASH:
        out[0] = CRASH[level]
    return out


@pytest.mark.parametrize("n", [1, 3])  # one world takes the scalar env's own step
@pytest.mark.parametrize("level", LEVELS)
def test_world_i_is_the_scalar_env_seeded_s_plus_i(level, n):
    """Observations, rewards, flags and infos (labels included) of each world equal the scalar
    env's (gym.make, same kwargs, seed s + i), through terminations, truncations (a 20-step
    limit) and next-step autoresets."""
    seed, limit = 11, 20
    kwargs = {**SMALL, "action_level": level, "max_episode_steps": limit}
    vec = make_vec("FLUIDS-v1", n, **kwargs)
    scalars = [gym.make("FLUIDS-v1", **kwargs) for _ in range(n)]
    space = scalars[0].action_space
    space.seed(0)
    rng = np.random.default_rng(0)
    obs, info = vec.reset(seed=seed)
    ref = [env.reset(seed=seed + i) for i, env in enumerate(scalars)]
    assert same(obs, np.stack([o for o, _ in ref]))
    assert same(info, batched([i for _, i in ref]))
    ended = np.zeros(n, dtype=bool)
    seen = {"terminated": 0, "truncated": 0, "autoreset": 0}
    for t in range(limit + 4):
        actions = actions_for(level, space, info["supervisor_action"], rng, t)
        obs, rewards, terminated, truncated, info = vec.step(actions)
        rows, ref_infos, ref_flags = [], [], []
        for i, env in enumerate(scalars):
            if ended[i]:  # next-step autoreset: the scalar env continues its own generator
                o, inf = env.reset()
                r, term, trunc = 0.0, False, False
                seen["autoreset"] += 1
            else:
                o, r, term, trunc, inf = env.step(actions[i])
            rows.append(o)
            ref_infos.append(inf)
            ref_flags.append((r, term, trunc))
        assert same(obs, np.stack(rows)), (t, level)
        assert same(rewards, np.array([f[0] for f in ref_flags]))
        assert same(terminated, np.array([f[1] for f in ref_flags]))
        assert same(truncated, np.array([f[2] for f in ref_flags]))
        assert same(info, batched(ref_infos)), (t, level)
        assert same(vec.supervisor_action(), info["supervisor_action"])
        # is_success comes with each termination (not with a truncation)
        assert np.array_equal(info.get("_is_success", np.zeros(n, bool)), terminated)
        seen["terminated"] += int(terminated.sum())
        seen["truncated"] += int(truncated.sum())
        ended = terminated | truncated
    assert seen["autoreset"]
    assert seen["truncated"] or (n == 1 and level in CRASH)  # (a lone crashing world ends first)
    if level in CRASH:
        assert seen["terminated"]


@pytest.mark.parametrize(
    "env_id,mode,extra",
    [
        ("FLUIDS-v0", "NextStep", {}),
        ("FLUIDS-Sensitivity-v1", "SameStep", {}),
        ("FLUIDS-v2", "Disabled", {}),
        # observations taken world by world: noisy (each world's generator), or several kinds
        ("FLUIDS-v1", "SameStep", {"obs_noise": 0.5}),
        ("FLUIDS-v2", "NextStep", {"obs_type": ["explicit", "qlidar"]}),
        ("FLUIDS-v2", "NextStep", {"action_level": "velocity"}),  # normalised targets
        # the quasi-LIDAR in one call: version 0, version 1 normalised
        ("FLUIDS-v0", "NextStep", {"obs_type": "qlidar"}),
        ("FLUIDS-Sensitivity-v2", "NextStep", {"action_level": "velocity"}),
    ],
)
def test_the_batch_equals_sync_vector_env(env_id, mode, extra):
    """Everything ``step`` and ``reset`` return equals SyncVectorEnv's over the same id, in
    each autoreset mode (Disabled: ended worlds reset through ``reset_mask``)."""
    n, limit = 3, 6
    kwargs = {**SMALL, "action_level": "control", "max_episode_steps": limit, **extra}
    vec = make_vec(env_id, n, autoreset_mode=mode, **kwargs)
    sync = gym.make_vec(
        env_id, n, vectorization_mode="sync", vector_kwargs={"autoreset_mode": mode}, **kwargs
    )
    assert vec.metadata["autoreset_mode"] == sync.metadata["autoreset_mode"]
    assert vec.single_action_space == sync.single_action_space
    assert vec.single_observation_space == sync.single_observation_space
    assert vec.action_space == sync.action_space
    assert vec.observation_space == sync.observation_space
    assert same(vec.reset(seed=[4, 9, 2]), sync.reset(seed=[4, 9, 2]))
    vec.action_space.seed(1)
    for t in range(2 * limit + 2):
        actions = vec.action_space.sample()
        actions[0] = CRASH.get(kwargs["action_level"], actions[0]) if t % 2 else actions[0]
        out = vec.step(actions)
        assert same(out, sync.step(actions)), t
        done = out[2] | out[3]
        if mode == "Disabled" and done.any():
            options = {"reset_mask": done}
            assert same(vec.reset(options=dict(options)), sync.reset(options=dict(options)))


def test_every_fluids_id_has_the_vector_entry_point():
    """Registry-driven: a new FLUIDS id gets the entry point, the scalar env's spaces, its step
    limit, one shared layout, and a few steps equal to SyncVectorEnv's."""
    for env_id in FLUIDS_IDS:
        vec = make_vec(env_id, 2, **SMALL)
        single = gym.make(env_id, **SMALL)
        sync = gym.make_vec(env_id, 2, vectorization_mode="sync", **SMALL)
        out = vec.reset(seed=21)
        assert same(out, sync.reset(seed=21)), env_id
        for _ in range(4):
            actions = out[-1]["supervisor_action"]
            out = vec.step(actions)
            assert same(out, sync.step(actions)), env_id
        assert isinstance(vec, FluidsVectorEnv), env_id
        assert vec.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
        assert vec.max_episode_steps == gym.spec(env_id).max_episode_steps
        assert vec.single_action_space == single.action_space
        assert vec.single_observation_space == single.observation_space
        assert vec.action_space == batch_space(single.action_space, 2)
        # one compiled layout for every world
        layouts = {id(env.world.layout) for env in vec.envs}
        assert layouts == {id(single.unwrapped.world.layout)}, env_id


def test_seeds_int_list_and_numpy():
    vec = make_vec("FLUIDS-v0", 3, **SMALL)
    by_int = vec.reset(seed=7)
    assert same(vec.reset(seed=[7, 8, 9]), by_int)
    assert same(vec.reset(seed=np.int64(7)), by_int)
    assert not np.array_equal(vec.reset(seed=8)[0], by_int[0])
    for bad in ("7", 1.5, [1, 2]):
        with pytest.raises(ValueError, match="'seed'"):
            vec.reset(seed=bad)


def test_snapshots_move_between_the_batch_and_scalar_envs():
    """World 1's snapshot continues in a gym.make env (and a scalar env's in world 0) exactly,
    truncating at the same step."""
    limit = 12
    kwargs = {**SMALL, "action_level": "velocity", "max_episode_steps": limit}
    vec = make_vec("FLUIDS-v1", 2, **kwargs)
    vec.reset(seed=3)
    actions = np.array([[3.0], [6.0]], np.float32)
    for _ in range(5):
        vec.step(actions)
    scalar = gym.make("FLUIDS-v1", **kwargs)
    scalar.reset(seed=0)  # (gym.make's env checker wants a reset before the first step)
    snapshots.restore(scalar, vec.snapshot(1))
    other = gym.make("FLUIDS-v1", **kwargs)
    other.reset(seed=40)
    for _ in range(3):
        other.step(np.array([4.0], np.float32))
    vec.restore(0, snapshots.snapshot(other))
    live = {0: other, 1: scalar}
    for _ in range(limit - 3):
        obs, rewards, terminated, truncated, info = vec.step(actions)
        for i, env in list(live.items()):
            o, r, term, trunc, inf = env.step(actions[i])
            assert same(obs[i], o) and rewards[i] == r
            assert (terminated[i], truncated[i]) == (term, trunc)
            assert same(info["supervisor_action"][i], inf["supervisor_action"])
            if term or trunc:
                del live[i]
    assert truncated[0]  # restored at step 3 of 12: truncated 9 steps on, as the scalar env
    with pytest.raises(ValueError, match="'index'"):
        vec.snapshot(2)
    with pytest.raises(TypeError, match="WrappedSnapshot"):
        vec.restore(0, other.unwrapped.snapshot())


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"num_envs": 0}, "'num_envs'"),
        ({"num_envs": 2.0}, "'num_envs'"),
        ({"num_envs": True}, "'num_envs'"),
        ({"num_cars": -1}, "'num_cars'"),
        ({"action_levle": "velocity"}, "unknown argument.*'action_levle'.*num_envs"),
        ({"autoreset_mode": "sometimes"}, "'autoreset_mode'"),
        ({"render_mode": "human"}, "'render_mode'"),
        ({"max_episode_steps": 0}, "'max_episode_steps'"),
    ],
)
def test_bad_arguments_are_clear_value_errors(kwargs, match):
    kwargs = {"num_envs": 2, **kwargs}
    with pytest.raises(ValueError, match=match):
        gym.make_vec("FLUIDS-v1", vectorization_mode="vector_entry_point", **kwargs)


@pytest.mark.parametrize(
    "level,actions,match",
    [
        ("velocity", np.zeros((3,), np.float32), r"shape \(3,\).*\(2, 1\)"),
        ("velocity", np.array([[1.0], [np.nan]]), r"actions\[1\].*not finite"),
        ("velocity", np.array([["1"], ["2"]]), "dtype"),
        ("control", np.ones((2, 2), bool), "dtype"),
        ("behavior", np.array([0, 99]), r"actions\[1\] is 99"),
        ("behavior", np.array([0.0, 1.0]), "integers"),
    ],
)
def test_bad_actions_are_refused_before_any_world_moves(level, actions, match):
    vec = make_vec("FLUIDS-v1", 2, **SMALL, action_level=level)
    sync = gym.make_vec("FLUIDS-v1", 2, vectorization_mode="sync", **SMALL, action_level=level)
    assert same(vec.reset(seed=5), sync.reset(seed=5))
    with pytest.raises(ValueError, match=match):
        vec.step(actions)
    good = vec.supervisor_action()
    assert same(vec.step(good), sync.step(good))  # no world moved on the refused batch


def test_step_before_reset_and_rendering():
    vec = make_vec("FLUIDS-v0", 2, **SMALL, render_mode="rgb_array")
    with pytest.raises(RuntimeError, match="before reset"):
        vec.step(np.zeros((2, 2), np.float32))
    vec.reset(seed=0)
    frames = vec.render()
    assert len(frames) == 2 and frames[0].ndim == 3 and frames[0].dtype == np.uint8
    vec.close()


@pytest.mark.slow
@pytest.mark.parametrize("level", ["velocity", "behavior"])
def test_long_episodes_equal_sync_vector_env(level):
    """The registered FLUIDS-v1 scene and step limit, 4 worlds following their labels (world 0
    at top speed at the velocity level) for 700 steps: arrivals, collisions, the 600-step
    truncation and autoresets, equal to SyncVectorEnv throughout."""
    n = 4
    vec = make_vec("FLUIDS-v1", n, action_level=level)
    sync = gym.make_vec("FLUIDS-v1", n, vectorization_mode="sync", action_level=level)
    out = vec.reset(seed=100)
    assert same(out, sync.reset(seed=100))
    ended = 0
    for _ in range(700):
        actions = out[-1]["supervisor_action"].copy()
        if level == "velocity":
            actions[0] = vec.single_action_space.high
        out = vec.step(actions)
        assert same(out, sync.step(actions))
        ended += int((out[2] | out[3]).sum())
    assert ended >= n


@pytest.mark.parametrize("level", ["velocity", "control"])
def test_worlds_whose_ego_arrived_drive_on_as_sync_vector_env(level):
    """``done_when="all"``: after the ego arrives its action is ignored while the others drive
    on (the batched actions must skip that world's ego), equal to SyncVectorEnv."""
    n, kwargs = 3, {**SMALL, "action_level": level, "done_when": "all"}
    vec = make_vec("FLUIDS-v1", n, **kwargs)
    sync = gym.make_vec("FLUIDS-v1", n, vectorization_mode="sync", **kwargs)
    out = vec.reset(seed=5)
    assert same(out, sync.reset(seed=5))
    ego_gone = 0
    for _ in range(400):
        actions = out[-1]["supervisor_action"]
        out = vec.step(actions)
        assert same(out, sync.step(actions))
        ego_gone += sum(not env.world.active[0] for env in vec.envs)
        if ego_gone > 20:
            break
    assert ego_gone > 20


def test_recovery_paths_are_planned_as_in_sync_vector_env():
    """An ego steered off its lane (two-lane layout, on the road) gets a recovery path: the
    batch finds it off its route and plans, equal to SyncVectorEnv."""
    n, kwargs = 3, {**SMALL, "action_level": "control", "lanes": 2}
    vec = make_vec("FLUIDS-v1", n, **kwargs)
    sync = gym.make_vec("FLUIDS-v1", n, vectorization_mode="sync", **kwargs)
    out = vec.reset(seed=11)
    assert same(out, sync.reset(seed=11))
    for t in range(30):
        actions = out[-1]["supervisor_action"].copy()
        if 3 <= t < 25:
            actions[0] = [0.4, 0.5]  # drift left into the other lane
        out = vec.step(actions)
        assert same(out, sync.step(actions)), t
    assert vec.unwrapped.envs[0].supervisor.recoveries > 0


def test_disabled_autoreset_refuses_to_step_an_ended_world():
    vec = make_vec("FLUIDS-v0", 2, **SMALL, autoreset_mode="Disabled", max_episode_steps=2)
    out = vec.reset(seed=0)
    for _ in range(2):
        out = vec.step(out[-1]["supervisor_action"])
    assert out[3].all()
    before = [vec.unwrapped.snapshot(i) for i in range(2)]
    with pytest.raises(RuntimeError, match="reset_mask"):
        vec.step(out[-1]["supervisor_action"])
    assert [vec.unwrapped.snapshot(i) for i in range(2)] == before  # no world moved


def test_call_and_attributes_as_sync_vector_env():
    vec = make_vec("FLUIDS-v0", 2, **SMALL)
    sync = gym.make_vec("FLUIDS-v0", 2, vectorization_mode="sync", **SMALL)
    vec.reset(seed=1)
    sync.reset(seed=1)
    assert same(vec.call("supervisor_action"), sync.call("supervisor_action"))
    assert vec.get_attr("action_level") == sync.get_attr("action_level") == ("control",) * 2
    vec.set_attr("marker", [1, 2])
    assert vec.get_attr("marker") == (1, 2)
    with pytest.raises(ValueError, match="'values'"):
        vec.set_attr("marker", [1, 2, 3])
