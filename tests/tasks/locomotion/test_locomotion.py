"""Locomotion IL envs: Gymnasium's MuJoCo v5 envs behind the supervisor protocol.

Real MuJoCo, real rollouts, real Minari files. The planner is shrunk (few samples, short
horizon) where only the plumbing is under test; the shipped supervisors' quality is in
test_locomotion_quality.py.
"""

from __future__ import annotations

import json
import pickle
import warnings

import gymnasium as gym
import minari
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.noise import isotropic_actor
from fluids_bench.algos.rollout import rollout
from fluids_bench.data.locomotion import export_supervisor_dataset
from fluids_bench.tasks.locomotion.env import DEFAULT_SUPERVISOR
from fluids_bench.tasks.locomotion.mpc import MPCConfig, SamplingMPC
from fluids_bench.tasks.locomotion.policy import MLPPolicy, sha256_of
from fluids_bench.tasks.locomotion.supervisors import load_policy, manifest

IDS = ["Hopper-IL-v0", "Walker2d-IL-v0", "HalfCheetah-IL-v0", "Humanoid-IL-v0"]
SMALL = {"mpc": {"samples": 6, "horizon": 4}}  # a cheap planner: plumbing tests only
# Gymnasium's own MuJoCo envs declare unbounded observation boxes; check_env warns about it.
ALLOWED_WARNINGS = (
    "A Box observation space minimum value is -infinity",
    "A Box observation space maximum value is infinity",
)


def small(env_id: str) -> dict:
    """Kwargs that keep the id's default supervisor cheap (a tiny planner for MPC ids)."""
    return SMALL if DEFAULT_SUPERVISOR[env_id.split("-")[0]] != "policy" else {}


def make(env_id: str, **kwargs) -> gym.Env:
    if kwargs.get("supervisor") == "policy":
        return gym.make(env_id, **kwargs)
    if "mpc" in kwargs and "supervisor" not in kwargs:
        kwargs["supervisor"] = "mpc"
    return gym.make(env_id, **{**small(env_id), **kwargs})


def tiny_weights(tmp_path, env_id: str, hidden: int = 5, seed: int = 0):
    """A random MLP weight file of the right shape for ``env_id``, and its sha256."""
    env = gym.make(env_id.replace("-IL-v0", "-v5"))
    obs_dim, act_dim = env.observation_space.shape[0], env.action_space.shape[0]
    rng = np.random.default_rng(seed)
    policy = MLPPolicy(
        np.zeros(obs_dim),
        np.ones(obs_dim),
        [rng.standard_normal((hidden, obs_dim)), rng.standard_normal((act_dim, hidden))],
        [rng.standard_normal(hidden), rng.standard_normal(act_dim)],
        env.action_space.low,
        env.action_space.high,
    )
    path = tmp_path / f"{env_id}.npz"
    path.write_bytes(policy.to_bytes())
    return str(path), sha256_of(path), policy


@pytest.mark.parametrize("env_id", IDS)
def test_check_env_and_supervisor_contract(env_id):
    env = make(env_id)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped, skip_render_check=True)
    unexpected = [
        str(w.message) for w in caught if not any(a in str(w.message) for a in ALLOWED_WARNINGS)
    ]
    assert unexpected == []
    obs, info = env.reset(seed=3)
    for _ in range(3):
        label = info["supervisor_action"]
        assert env.action_space.contains(label)
        assert np.array_equal(label, env.unwrapped.supervisor_action())
        assert np.array_equal(env.unwrapped.supervisor_action(), env.unwrapped.supervisor_action())
        obs, _, _, _, info = env.step(env.action_space.sample())


@pytest.mark.parametrize("env_id", IDS)
def test_an_action_outside_the_space_is_applied_clipped_with_a_finite_reward(env_id):
    """Gymnasium's v5 env charged 1e155 its squared control cost: a reward of -inf. Clipped
    before it is applied, a huge action steps exactly as the space's bound does."""
    for huge in (1e155, -1e300, 1e6):
        a, b = make(env_id), make(env_id)
        a.reset(seed=5)
        b.reset(seed=5)
        bound = a.action_space.high if huge > 0 else a.action_space.low
        ra = a.step(np.full(a.action_space.shape, huge))
        rb = b.step(bound.copy())
        assert np.isfinite(ra[1]) and ra[1] == rb[1]
        assert np.array_equal(ra[0], rb[0])
    for bad in (np.inf, np.nan):  # not finite: refused, never clipped
        with pytest.raises(ValueError, match="not finite"):
            a.step(np.full(a.action_space.shape, bad))


@pytest.mark.parametrize("env_id", IDS)
def test_reset_matches_gymnasium_and_seeded_rollouts_repeat(env_id):
    bare = gym.make(env_id.replace("-IL-v0", "-v5"))
    a, b = make(env_id), make(env_id)
    oa, ia = a.reset(seed=11)
    ob, ib = b.reset(seed=11)
    assert np.array_equal(oa, bare.reset(seed=11)[0])
    assert not np.array_equal(oa, a.reset(seed=12)[0])  # initial states vary with the seed
    a.reset(seed=11)
    actions = np.random.default_rng(0).uniform(-0.4, 0.4, (6, a.action_space.shape[0]))
    for act in actions:
        ra, rb = a.step(act), b.step(act)
        rbare = bare.step(act)
        assert np.array_equal(ra[0], rb[0]) and ra[1] == rb[1]
        assert np.array_equal(ra[0], rbare[0]) and ra[1] == rbare[1]  # physics untouched
        assert np.array_equal(ra[4]["supervisor_action"], rb[4]["supervisor_action"])
    obs = a.step(actions[0])[0]
    obs[:] = 1e3  # the observation is a copy: writing it changes nothing inside
    assert not np.array_equal(obs, a.unwrapped._sim._get_obs())


@pytest.mark.parametrize("env_id", IDS)
def test_pickle_mid_episode_continues_identically(env_id):
    env = make(env_id)
    env.reset(seed=5)
    for _ in range(4):
        env.step(env.action_space.sample())
    copy = pickle.loads(pickle.dumps(env))
    for act in np.random.default_rng(1).uniform(-1, 1, (4, env.action_space.shape[0])):
        x, y = env.step(act), copy.step(act)
        assert np.array_equal(x[0], y[0]) and x[1] == y[1] and x[2] == y[2]
        assert np.array_equal(x[4]["supervisor_action"], y[4]["supervisor_action"])


@pytest.mark.parametrize("env_id", ["Hopper-IL-v0", "HalfCheetah-IL-v0", "Humanoid-IL-v0"])
def test_mpc_label_is_a_pure_function_of_the_state(env_id):
    """The same state reached twice (here: copied into a fresh env) gives the same label, and
    the label follows the state (different states, different labels)."""
    a, b = (
        make(env_id, mpc={"samples": 16, "horizon": 8}),
        make(env_id, mpc={"samples": 16, "horizon": 8}),
    )
    a.reset(seed=2)
    b.reset(seed=99)
    labels = []
    for _ in range(3):
        a.step(a.action_space.sample() * 0.3)
        labels.append(a.unwrapped.supervisor_action())
    first = labels[-1]
    assert np.array_equal(first, a.unwrapped.supervisor_action())
    if env_id != "Humanoid-IL-v0":  # a 16-sample planner keeps the humanoid's zero plan here
        assert len({label.tobytes() for label in labels}) > 1
    src, dst = a.unwrapped._sim, b.unwrapped._sim
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    x = np.empty(mujoco.mj_stateSize(src.model, spec))
    mujoco.mj_getState(src.model, src.data, x, spec)
    mujoco.mj_setState(dst.model, dst.data, x, spec)
    dst.data.qacc_warmstart[:] = src.data.qacc_warmstart
    assert np.array_equal(first, b.unwrapped.supervisor_action())


@pytest.mark.parametrize("task", ["Hopper", "HalfCheetah", "Humanoid"])
def test_mpc_rollouts_reproduce_env_step_bit_for_bit(task):
    """The planner's model is exact: a plan rolled out by mujoco.rollout from a cloned state
    lands where env.step lands with the same actions."""
    env = gym.make(f"{task}-v5").unwrapped
    env.reset(seed=0)
    mpc = SamplingMPC(
        MPCConfig(task=task, samples=2, horizon=5), env.model, env.frame_skip, env.fullpath
    )
    x0 = np.empty(mpc.nstate)
    mujoco.mj_getState(mpc.model, env.data, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    plan = np.random.default_rng(0).uniform(-0.4, 0.4, (1, 5, env.action_space.shape[0]))
    state, _ = mpc._rollout(x0, env.data.qacc_warmstart.copy(), plan)
    for act in plan[0]:
        env.step(act)
    final = np.empty(mpc.nstate)
    mujoco.mj_getState(env.model, env.data, final, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    assert np.array_equal(state[0, -1], final)


def test_policy_supervisor_weights_hash_checked(tmp_path):
    path, sha, policy = tiny_weights(tmp_path, "Hopper-IL-v0")
    env = gym.make("Hopper-IL-v0", supervisor="policy", weights=path, weights_sha256=sha)
    obs, info = env.reset(seed=0)
    assert np.array_equal(info["supervisor_action"], policy(obs).astype(np.float32))
    record = env.unwrapped.metadata["supervisor"]
    assert record["kind"] == "policy" and record["weights_sha256"] == sha
    with pytest.raises(ValueError, match="sha256"):
        gym.make("Hopper-IL-v0", supervisor="policy", weights=path, weights_sha256="0" * 64)
    with pytest.raises(ValueError, match="weights_sha256"):
        gym.make("Hopper-IL-v0", supervisor="policy", weights=path)
    wrong, wrong_sha, _ = tiny_weights(tmp_path, "HalfCheetah-IL-v0")
    with pytest.raises(ValueError, match="observation size"):
        gym.make("Hopper-IL-v0", supervisor="policy", weights=wrong, weights_sha256=wrong_sha)


def test_policy_is_not_linear_in_the_observation(tmp_path):
    """The squashing makes the best linear fit of the policy's labels leave a residual."""
    _, _, policy = tiny_weights(tmp_path, "Hopper-IL-v0", seed=3)
    obs = np.random.default_rng(0).standard_normal((400, policy.obs_dim)) * 3
    labels = policy(obs)
    design = np.hstack([obs, np.ones((len(obs), 1))])
    coef, *_ = np.linalg.lstsq(design, labels, rcond=None)
    assert np.mean((design @ coef - labels) ** 2) > 1e-3
    assert np.allclose(policy(obs)[7], policy(obs[7]))  # batched == one at a time


@pytest.mark.parametrize("hidden", [0, 1, 2])
def test_compiled_label_is_the_numpy_forward_pass_in_float32(hidden):
    """``act32`` (the label) and ``__call__`` (training's forward pass) differ only in float64
    rounding: in float32 they agree on (almost) every state, within one float32 step."""
    rng = np.random.default_rng(hidden)
    dims = [11, *[16] * hidden, 3]
    policy = MLPPolicy(
        rng.normal(0, 1, 11),
        rng.uniform(0.5, 2, 11),
        [rng.normal(0, 0.5, (o, i)) for i, o in zip(dims[:-1], dims[1:], strict=True)],
        [rng.normal(0, 0.5, o) for o in dims[1:]],
        -np.ones(3),
        np.ones(3),
    )
    obs = rng.normal(0, 3, (2000, 11))
    ref = policy(obs).astype(np.float32)
    got = np.stack([policy.act32(o) for o in obs])
    assert got.dtype == np.float32
    assert np.mean(got == ref) > 0.999
    assert np.max(np.abs(got - ref)) <= np.spacing(np.float32(1.0))
    for task in manifest():  # the shipped policies, on states of their own rollouts
        shipped, _ = load_policy(task)
        env = gym.make(f"{task}-IL-v0", supervisor="policy")
        o, info = env.reset(seed=0)
        states = []
        for _ in range(200):
            states.append(o)
            o, _, _, _, info = env.step(info["supervisor_action"])
        states = np.array(states)
        assert np.array_equal(
            np.stack([shipped.act32(x) for x in states]), shipped(states).astype(np.float32)
        ), task


def test_guided_mpc_starts_from_the_policy_plan(tmp_path):
    path, sha, _ = tiny_weights(tmp_path, "HalfCheetah-IL-v0")
    env = gym.make(
        "HalfCheetah-IL-v0",
        supervisor="guided_mpc",
        weights=path,
        weights_sha256=sha,
        mpc={"samples": 4, "horizon": 5},
    )
    env.reset(seed=0)
    label = env.unwrapped.supervisor_action()
    assert np.array_equal(label, env.unwrapped.supervisor_action())
    assert env.unwrapped.metadata["supervisor"]["kind"] == "guided_mpc"
    assert env.unwrapped.metadata["supervisor"]["weights_sha256"] == sha


@pytest.mark.parametrize("env_id", ["Walker2d-IL-v0", "HalfCheetah-IL-v0", "Humanoid-IL-v0"])
def test_guided_plan_is_the_policys_own_closed_loop_run_in_the_env(env_id, tmp_path):
    """The planner's nominal plan is what the policy would do in the env over the horizon, bit
    for bit: its simulated observations are the env's (Humanoid's include inertias,
    velocities and contact forces; Walker2d clips joint velocities to +-10, HalfCheetah does
    not, so the state is given fast joints)."""
    path, sha, policy = tiny_weights(tmp_path, env_id)
    env = gym.make(
        env_id, supervisor="guided_mpc", weights=path, weights_sha256=sha, mpc={"horizon": 6}
    ).unwrapped
    env.reset(seed=3)
    for _ in range(5):  # a state with contacts
        env.step(env.action_space.sample() * 0)
    env._sim.data.qvel[-3:] += 12.0
    mpc = env._supervisor.mpc
    x0 = np.empty(mpc.nstate)
    mujoco.mj_getState(mpc.model, env._sim.data, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    plan = mpc._prior_plan(env._sim.data, x0, np.array(env._sim.data.qacc_warmstart))
    gym_env = env._sim
    for k in range(6):
        expected = np.clip(
            policy(gym_env._get_obs()), gym_env.action_space.low, gym_env.action_space.high
        )
        assert np.array_equal(plan[k], expected), k
        gym_env.step(plan[k])


def test_dart_noise_executes_noisy_actions_but_stores_labels():
    env = make("HalfCheetah-IL-v0")
    actor = isotropic_actor(env.action_space, noise_std=0.3, epsilon=0.0)
    traj = rollout(env, actor, seed=4, max_steps=8)
    assert not np.allclose(traj.actions, traj.labels)  # the executed actions carry the noise
    replay = make("HalfCheetah-IL-v0")
    _, info = replay.reset(seed=4)
    for t in range(8):
        assert np.array_equal(
            traj.labels[t], info["supervisor_action"]
        )  # labels are the supervisor's
        _, _, _, _, info = replay.step(traj.actions[t])


@pytest.mark.parametrize("env_id", IDS)
def test_minari_export_and_recover_environment(env_id, tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "datasets"))
    name = env_id.split("-")[0].lower()
    dataset = export_supervisor_dataset(
        f"locomotion/{name}-test-v0",
        env_id,
        2,
        seed=0,
        env_kwargs=small(env_id),
        noise_std=0.1,
        max_steps=5,
    )
    assert dataset.total_steps == 10
    loaded = minari.load_dataset(f"locomotion/{name}-test-v0")
    record = json.loads(loaded.storage.metadata["description"])
    meta = gym.make(env_id, **small(env_id)).unwrapped.metadata
    assert record["supervisor"] == json.loads(json.dumps(meta["supervisor"]))
    if small(env_id):  # a shrunk planner: its return is not measured, so no reference scores
        assert "ref_max_score" not in loaded.storage.metadata
    else:
        assert loaded.storage.metadata["ref_min_score"] == meta["reference_scores"]["random"]
        assert loaded.storage.metadata["ref_max_score"] == meta["reference_scores"]["supervisor"]
        assert record["supervisor"]["weights_sha256"] == meta["supervisor"]["weights_sha256"]
    recovered = loaded.recover_environment()
    episode = next(loaded.iterate_episodes())
    obs, info = recovered.reset(seed=0)
    assert np.array_equal(obs, episode.observations[0])
    assert np.array_equal(info["supervisor_action"], episode.actions[0])  # labels stored


def test_rgb_array_render():
    env = make("HalfCheetah-IL-v0", render_mode="rgb_array", width=96, height=64)
    env.reset(seed=0)
    frame = env.render()
    env.close()
    assert frame.shape == (64, 96, 3) and frame.dtype == np.uint8 and frame.std() > 0


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"supervisr": "mpc"}, "supervisr"),
        ({"supervisor": "trpo"}, "supervisor"),
        ({"supervisor": "mpc", "mpc": {"sample": 3}}, "mpc key"),
        ({"width": 3}, "width"),
        ({"render_mode": "rgb"}, "render_mode"),
        ({"supervisor": "policy", "mpc": {"samples": 3}}, "mpc"),
        ({"supervisor": "mpc", "weights": "x.npz", "weights_sha256": "0" * 64}, "weights"),
        ({"supervisor": "policy", "weights": "x.npz"}, "weights_sha256"),
    ],
)
@pytest.mark.filterwarnings("ignore:.*render_mode")  # gym.make warns before the env raises
def test_bad_arguments_raise_value_errors(kwargs, field):
    with pytest.raises(ValueError, match=field):
        gym.make("Walker2d-IL-v0", **kwargs)


def test_mpc_config_validates():
    with pytest.raises(ValueError, match="samples"):
        MPCConfig(task="Hopper", samples=0)
    with pytest.raises(ValueError, match="task"):
        MPCConfig(task="Ant")
    assert MPCConfig(task="Hopper", samples=np.int64(3).item()).samples == 3


def _damaged_weights(tmp_path, damage: str) -> str:
    """Hopper weight bytes spoilt in one way (written with numpy.savez, as a user might)."""
    path, _, policy = tiny_weights(tmp_path, "Hopper-IL-v0")
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    if damage == "truncated":
        data = open(path, "rb").read()
        bad = tmp_path / "truncated.npz"
        bad.write_bytes(data[: len(data) // 2])
        return str(bad)
    if damage == "obs_std=0":
        arrays["obs_std"][3] = 0.0
    elif damage == "nan":
        arrays["W0"][0, 0] = np.nan
    elif damage == "bounds":
        arrays["action_low"] = arrays["action_low"] * 2.0
    elif damage == "missing":
        del arrays["b1"]
    elif damage == "extra":  # was silently ignored
        arrays["W_extra"] = arrays["W0"]
    elif damage == "extra layer bias":
        arrays["b7"] = arrays["b0"]
    elif damage == "low>high":
        arrays["action_low"], arrays["action_high"] = arrays["action_high"], arrays["action_low"]
    bad = tmp_path / f"{damage}.npz"
    np.savez(bad, **arrays)
    return str(bad)


@pytest.mark.parametrize(
    ("damage", "named"),
    [
        ("obs_std=0", "obs_std has 1 entries <= 0 or NaN"),  # was ZeroDivisionError / inf labels
        ("nan", "W0 holds 1 NaN"),  # was NaN labels
        ("bounds", "action bounds .*allowed: inside Hopper's action space"),
        ("low>high", "action_low is not below action_high"),
        ("missing", r"missing arrays \['b1'\]"),  # was KeyError
        ("extra", r"unknown arrays \['W_extra'\]"),  # was silently ignored
        ("extra layer bias", r"unknown arrays \['b7'\]"),
        ("truncated", "not a readable .npz"),  # was BadZipFile
    ],
)
def test_user_weights_are_validated_at_load_naming_the_file(tmp_path, damage, named):
    path = _damaged_weights(tmp_path, damage)
    with pytest.raises(ValueError, match=rf"{path}.*{named}|{named}.*{path}") as caught:
        gym.make("Hopper-IL-v0", supervisor="policy", weights=path, weights_sha256=sha256_of(path))
    assert path in str(caught.value)
