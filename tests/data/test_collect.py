"""Parallel collection: make_vec for every registered id, and the collector's backends.

Registry-driven: every id of ENV_SPECS is tested; an id whose module does not import fails.
The Ray tests need Ray installed (the ``ray`` extra): without it they fail, by design.
"""

from __future__ import annotations

import sys

import gymnasium as gym
import numpy as np
import pytest

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.policies import PolicySpec, fit_policy
from fluids_bench.core.parallel import import_ray
from fluids_bench.data.collect import ActorSpec, collect
from fluids_bench.registration import ENV_SPECS

IDS = sorted(ENV_SPECS)
# short episodes keep the whole file well under a minute on two cores
SHORT = {"FLUIDS-v0": 40, "FLUIDS-Sensitivity-v0": 40}
# the locomotion ids run 1,000 steps and some label with a planner (tens of ms to a second)
SHORT.update({f"{name}-IL-v0": 5 for name in ("Hopper", "Walker2d", "HalfCheetah", "Humanoid")})


def _noise_for(env_id: str) -> ActorSpec:
    discrete = isinstance(gym.make(env_id).action_space, gym.spaces.Discrete)
    return ActorSpec("noise", epsilon=0.3) if discrete else ActorSpec("noise", noise_std=0.3)


def _assert_same(a, b) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert x.seed == y.seed and x.terminated == y.terminated and x.truncated == y.truncated
        for name in ("observations", "actions", "labels", "rewards"):
            u, v = getattr(x, name), getattr(y, name)
            assert u.dtype == v.dtype and np.array_equal(u, v), name


def _vector_rollout(env_id: str, mode: str, steps: int = 12) -> list:
    kwargs = {"vector_kwargs": {"context": "spawn"}} if mode == "async" else {}
    envs = gym.make_vec(env_id, 2, vectorization_mode=mode, **kwargs)
    try:
        obs, info = envs.reset(seed=[11, 12])
        out = [obs]
        for _ in range(steps):
            obs, reward, term, trunc, info = envs.step(info["supervisor_action"])
            out += [obs, reward, term, trunc, info["supervisor_action"]]
        return out
    finally:
        envs.close()


@pytest.mark.parametrize("env_id", IDS)
def test_make_vec_sync_and_async_agree(env_id):
    sync, asynchronous = _vector_rollout(env_id, "sync"), _vector_rollout(env_id, "async")
    for a, b in zip(sync, asynchronous, strict=True):
        assert a.dtype == b.dtype and np.array_equal(a, b)


@pytest.mark.parametrize("env_id", IDS)
def test_same_data_whatever_the_number_of_workers(env_id):
    """Forkserver workers (the default): tasks and results cross processes by pickling."""
    actor = _noise_for(env_id)
    steps = SHORT.get(env_id)
    one = collect(env_id, 3, actor=actor, seed=20, max_steps=steps, progress=False)
    two = collect(env_id, 3, actor=actor, seed=20, max_steps=steps, workers=2, progress=False)
    _assert_same(one, two)
    assert [t.seed for t in one] == [20, 21, 22]
    # episode i depends only on seed + i: a later start reproduces the tail
    _assert_same(one[1:], collect(env_id, 2, actor=actor, seed=21, max_steps=steps, progress=False))


def test_noise_changes_the_executed_action_not_the_label():
    box = collect(
        "FLUIDS-v0", 1, actor=ActorSpec("noise", noise_std=0.5), max_steps=30, progress=False
    )[0]
    assert np.all(np.any(box.actions != box.labels, axis=1))
    for t in range(len(box)):  # the label is the supervisor's for the state acted from
        np.testing.assert_array_equal(box.labels[t], box.infos[t]["supervisor_action"])
    space = gym.make("FLUIDS-v0").action_space
    assert all(space.contains(a) for a in box.actions)
    always = collect("GridWorld-v0", 2, actor=ActorSpec("noise", epsilon=1.0), progress=False)
    for trajectory in always:
        assert np.all(trajectory.actions != trajectory.labels)
    clean = collect("FLUIDS-v0", 1, max_steps=30, progress=False)[0]
    np.testing.assert_array_equal(clean.actions, clean.labels)


def test_learner_acts_and_the_supervisor_labels():
    demo = collect("GridWorld-v0", 2, progress=False)
    observations = np.concatenate([t.states for t in demo])
    labels = np.concatenate([t.labels for t in demo])
    policy = fit_policy(
        PolicySpec("constant"),
        gym.make("GridWorld-v0").action_space,
        observations,
        labels,
        random_state=0,
    )
    actor = ActorSpec("learner", policy=policy)
    runs = collect("GridWorld-v0", 2, actor=actor, seed=3, workers=2, progress=False)
    for trajectory in runs:
        np.testing.assert_array_equal(trajectory.actions, policy.predict(trajectory.states))
    assert any(np.any(t.actions != t.labels) for t in runs)


def test_bad_arguments_raise():
    with pytest.raises(ValueError, match="episodes"):
        collect("DAG-v0", 0)
    with pytest.raises(ValueError, match="backend"):
        collect("DAG-v0", 1, backend="dask")
    with pytest.raises(ValueError, match="unknown env id"):
        collect("NoSuchEnv-v0", 1)
    with pytest.raises(ValueError, match="policy"):
        ActorSpec("learner")
    with pytest.raises(ValueError, match="epsilon"):
        ActorSpec("noise", epsilon=1.5)


def test_missing_ray_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # makes `import ray` fail
    with pytest.raises(ImportError, match=r'pip install "fluids-bench\[ray\]"'):
        import_ray()
    with pytest.raises(ImportError, match="fluids-bench"):
        collect("DAG-v0", 1, backend="ray", progress=False)


@pytest.fixture(scope="module")
def local_ray():
    ray = import_ray()  # no skip: without the ray extra this fails, naming the extra

    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("RAY_AUTH_MODE", "disabled")  # local instance: no token authentication
        ray.init(num_cpus=2, include_dashboard=False)
        yield ray
        ray.shutdown()


def test_ray_backend_gives_the_same_data(local_ray):
    kwargs = dict(actor=ActorSpec("noise", noise_std=0.3), seed=30, max_steps=20, progress=False)
    local = collect("FLUIDS-v0", 3, **kwargs)
    _assert_same(local, collect("FLUIDS-v0", 3, backend="ray", workers=2, **kwargs))
    assert local_ray.is_initialized(), "the collector must not stop a Ray it did not start"


def test_ray_backend_connects_to_a_given_address(monkeypatch):
    ray = import_ray()
    calls = []

    def init(**kwargs):
        calls.append(kwargs)
        raise ConnectionError("no cluster here")

    monkeypatch.setattr(ray, "is_initialized", lambda: False)
    monkeypatch.setattr(ray, "init", init)
    with pytest.raises(ConnectionError):
        collect("DAG-v0", 1, backend="ray", address="ray://head:10001", progress=False)
    assert calls == [{"address": "ray://head:10001"}]


@pytest.mark.parametrize("actor", [ActorSpec(), ActorSpec("noise", noise_std=0.3)])
def test_batched_collection_is_the_one_by_one_collection(actor):
    """`batch` episodes at a time on FLUIDS' vector env (worlds refilled, the last episodes in
    smaller envs): the trajectories of `batch=1`, with the same infos (up to number types)."""
    kwargs = {"num_cars": 2, "num_pedestrians": 1}
    runs = [
        collect("FLUIDS-v0", 5, env_kwargs=kwargs, actor=actor, seed=30, max_steps=steps,
                progress=False, batch=batch)
        for batch, steps in ((3, 60), (1, 60))
    ]  # fmt: skip
    _assert_same(*runs)
    for a, b in zip(*runs, strict=True):
        assert [sorted(i) for i in a.infos] == [sorted(i) for i in b.infos]
        assert [i.get("is_success") for i in a.infos] == [i.get("is_success") for i in b.infos]
