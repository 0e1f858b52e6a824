"""FLUIDS' RL-ready options (the v2 ids): normalised actions and labels, the reward that agrees
with ``is_success``, observations scaled to [-1, 1]."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.tasks.fluids.core import actions


def test_velocity_label_is_the_physical_label_normalised():
    v1 = gym.make("FLUIDS-v1", action_level="velocity")
    v2 = gym.make("FLUIDS-v2", action_level="velocity")
    assert v2.action_space.low[0] == -1 and v2.action_space.high[0] == 1
    (_, i1), (_, i2) = v1.reset(seed=7), v2.reset(seed=7)
    for _ in range(30):
        # same target speed in both: the physical label, and its normalised form
        a1 = i1["supervisor_action"]
        a2 = actions.to_normalized("velocity", v2.unwrapped.world, a1.astype(np.float64))
        assert np.allclose(i2["supervisor_action"], a2, atol=1e-6)
        back = actions.to_physical("velocity", v2.unwrapped.world, a2)
        assert np.allclose(back, a1, atol=1e-5)
        *_, i1 = v1.step(a1)
        *_, i2 = v2.step(i2["supervisor_action"])


def test_normalised_observations_are_the_physical_ones_scaled():
    """At the behavior level (no action scaling) v1 and v2 drive the same world: v2's
    observations are v1's mapped entry by entry, inside [-1, 1]."""
    for obs_type in ("explicit", "qlidar"):
        kw = {"action_level": "behavior", "obs_type": obs_type}
        v1, v2 = gym.make("FLUIDS-v1", **kw), gym.make("FLUIDS-v2", **kw)
        (o1, i1), (o2, _) = v1.reset(seed=3), v2.reset(seed=3)
        scale = v2.unwrapped.observer.parts[obs_type].scale
        for _ in range(40):
            assert o2.ndim == 1 and v2.observation_space.contains(o2)
            assert np.array_equal(o2, scale(o1))
            a = i1["supervisor_action"]
            o1, _, t1, _, i1 = v1.step(a)
            o2, _, t2, _, _ = v2.step(a)
            if t1:
                break


@pytest.mark.parametrize("env_id", ["FLUIDS-v2", "FLUIDS-Sensitivity-v2"])
def test_return_above_one_and_a_half_exactly_when_success(env_id):
    """Random target speeds (they run red lights, collide, time out, arrive): an episode's
    return exceeds 1.5 exactly when it succeeds."""
    env = gym.make(env_id, action_level="velocity", max_episode_steps=300)
    outcomes = []
    for seed in range(6):
        env.action_space.seed(seed)
        _, info = env.reset(seed=seed)
        ret = 0.0
        while True:
            _, r, term, trunc, info = env.step(env.action_space.sample())
            ret += r
            if term or trunc:
                break
        success = bool(info.get("is_success", False))
        outcomes.append(success)
        assert (ret > 1.5) == success, (seed, ret, info.get("is_success"))
        if success:
            assert ret >= 2.0 - 1e-9
    assert len(set(outcomes)) == 2, "both outcomes should occur in these seeds"


def test_end_on_violation_ends_the_episode_where_a_rule_is_broken_and_nothing_else_changes():
    """Full speed runs red lights and fails to yield: with ``end_on_violation`` the episode
    ends in the step of the first violation, with that step's reward and observation as
    without it, and ``is_success`` False (it could no longer hold)."""
    kw = {"action_level": "velocity", "max_episode_steps": 300}
    ended, violations = gym.make("FLUIDS-v2", end_on_violation=True, **kw), 0
    going_on = gym.make("FLUIDS-v2", **kw)
    assert ended.unwrapped.end_on_violation and not going_on.unwrapped.end_on_violation
    full = np.ones(1, dtype=np.float32)  # the fastest target speed
    for seed in range(8):
        (o1, _), (o2, _) = ended.reset(seed=seed), going_on.reset(seed=seed)
        while True:
            o1, r1, t1, tr1, i1 = ended.step(full)
            o2, r2, t2, tr2, i2 = going_on.step(full)
            assert np.array_equal(o1, o2) and r1 == r2 and tr1 == tr2
            broke = i2["ego_ran_red_light"] or i2["ego_failed_to_yield"]
            assert t1 == (t2 or broke)
            if t1 or tr1:
                break
        if broke:
            violations += 1
            assert i1["is_success"] is False and r1 < 0  # this step's progress, minus 1
    assert violations >= 2, "full speed should break a rule in some of these seeds"


def test_v3_is_v2_with_the_failure_terms_weighted_three():
    for family in ("FLUIDS-", "FLUIDS-Sensitivity-"):
        v2, v3 = gym.spec(family + "v2"), gym.spec(family + "v3")
        assert v3.kwargs == {**v2.kwargs, "failure_penalty": 3.0}
        assert v3.max_episode_steps == v2.max_episode_steps
    assert gym.make("FLUIDS-v3").unwrapped.failure_penalty == 3.0


def test_options_are_checked():
    with pytest.raises(ValueError, match="action_scale"):
        gym.make("FLUIDS-v1", action_scale="unit")
    with pytest.raises(ValueError, match="reward_version"):
        gym.make("FLUIDS-v1", reward_version=2)
    with pytest.raises(ValueError, match="obs_scale"):
        gym.make("FLUIDS-v1", obs_scale="whitened")
    with pytest.raises(ValueError, match="end_on_violation"):
        gym.make("FLUIDS-v1", end_on_violation="yes")


def test_failure_penalty_weights_only_the_failure_terms():
    """Same seed and actions: rewards differ by (penalty - 1) times the failure terms alone,
    in the scalar env and the vector env alike; the default keeps v2's rewards."""
    kw = {"action_level": "velocity", "max_episode_steps": 200}
    full = np.ones(1, dtype=np.float32)  # fast: red lights, failures to yield, collisions
    base, heavy = gym.make("FLUIDS-v2", **kw), gym.make("FLUIDS-v2", failure_penalty=3.0, **kw)
    diffs = []
    for seed in range(6):
        base.reset(seed=seed), heavy.reset(seed=seed)
        ran = yielded = False
        while True:
            *_, r1, t1, tr1, i1 = base.step(full)
            *_, r2, t2, tr2, _ = heavy.step(full)
            failures = (i1["ego_ran_red_light"] and not ran) + (
                i1["ego_failed_to_yield"] and not yielded
            )
            failures += any(c["a"] == 0 or c["b"] == 0 for c in i1["collisions"])
            ran, yielded = i1["ego_ran_red_light"], i1["ego_failed_to_yield"]
            assert r2 - r1 == pytest.approx(-2.0 * failures, abs=1e-9)
            diffs.append(failures)
            if t1 or tr1:
                break
    assert sum(diffs) >= 3, "full speed should fail in some of these seeds"
    vec = gym.make_vec(
        "FLUIDS-v2", 2, vectorization_mode="vector_entry_point", failure_penalty=3.0, **kw
    )
    sync = gym.make_vec("FLUIDS-v2", 2, vectorization_mode="sync", failure_penalty=3.0, **kw)
    vec.reset(seed=0), sync.reset(seed=0)
    for _ in range(150):
        a = np.ones((2, 1), dtype=np.float32)
        assert np.array_equal(vec.step(a)[1], sync.step(a)[1])
    with pytest.raises(ValueError, match="failure_penalty"):
        gym.make("FLUIDS-v1", failure_penalty=2.0)  # reward version 0
    with pytest.raises(ValueError, match="failure_penalty"):
        gym.make("FLUIDS-v2", failure_penalty=-1.0)


def _normalised_as_before(offset, gain, labels, obs):
    """The normalisation as first written (numpy temporaries, np.clip), the bits to keep."""
    x = (obs.astype(np.float64) - offset) * gain
    if labels:
        rows = obs.reshape(-1, 4)
        hot = np.arange(1, labels)[None, :] == np.rint(rows[:, 1:2]).astype(np.int64)
        x = np.concatenate([x.reshape(-1, 4)[:, [0, 2, 3]], hot], axis=1).reshape(-1)
    return np.clip(x, -1.0, 1.0).astype(np.float32)


@pytest.mark.parametrize("labels", [0, 6])
@pytest.mark.parametrize("shifted", [False, True])
def test_normaliser_gives_the_bits_of_its_first_formulation(labels, shifted):
    from fluids_bench.tasks.fluids.observations import _Normalizer

    rng = np.random.default_rng(labels + shifted)
    width = (64, 4) if labels else (50,)
    gain = rng.uniform(0.01, 2.0, width)
    offset = rng.normal(0.0, 3.0, width) if shifted else np.zeros(width)
    scale = _Normalizer(offset, gain, labels)
    for batch in ((), (5,)):
        for _ in range(50):
            obs = rng.normal(0.0, 40.0, batch + width) * rng.choice([1.0, 1e-3, 1e3], batch + width)
            obs = obs.astype(np.float32)
            if labels:
                obs[..., 1] = rng.integers(0, labels + 1, obs.shape[:-1])
            with np.errstate(invalid="ignore"):
                obs.reshape(-1)[rng.integers(0, obs.size, 3)] = [np.nan, -0.0, np.inf]
                want = _normalised_as_before(offset, gain, labels, obs)
            got = scale(obs)
            assert got.dtype == want.dtype and got.shape == want.shape
            assert got.tobytes() == want.tobytes()
