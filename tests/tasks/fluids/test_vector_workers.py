"""The FLUIDS vector env over worker processes (``num_workers``): the same results as one
``FluidsVectorEnv`` of all the worlds, bit for bit, in every autoreset mode and with uneven
slices; bad input refused in the parent; worker errors raised in the parent; workers stopped by
``close``."""

from __future__ import annotations

import os
import signal

import gymnasium as gym
import numpy as np
import pytest
from test_vector import SMALL, same

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core import snapshot as snapshots
from fluids_bench.tasks.fluids.vector import FluidsVectorEnv
from fluids_bench.tasks.fluids.vector.bounds import WORLD_BYTES, max_num_envs
from fluids_bench.tasks.fluids.vector.workers import FluidsWorkerVectorEnv, merge_infos, split


def make_vec(n: int, workers: int = 1, env_id: str = "FLUIDS-v1", **kwargs):
    return gym.make_vec(
        env_id, n, vectorization_mode="vector_entry_point", num_workers=workers, **kwargs
    )


def test_split_gives_contiguous_slices_differing_by_at_most_one():
    assert split(5, 2) == [0, 3, 5]
    assert split(6, 3) == [0, 2, 4, 6]
    assert split(3, 3) == [0, 1, 2, 3]


def test_merge_infos_types_each_key_by_its_first_slice_and_masks_the_rest():
    parts = [
        {"a": np.array([1, 2]), "_a": np.array([True, False])},
        {
            "a": np.array([3]),
            "_a": np.array([True]),
            "b": np.array(["x"], dtype=object),
            "_b": np.array([True]),
            "d": {"c": np.array([0.5]), "_c": np.array([True])},
            "_d": np.array([True]),
        },
    ]
    out = merge_infos(parts, [0, 2, 3])
    assert list(out) == ["a", "_a", "b", "_b", "d", "_d"]
    assert same(out["a"], np.array([1, 2, 3])) and same(out["_a"], np.array([True, False, True]))
    assert out["b"].dtype == object and list(out["b"]) == [None, None, "x"]
    assert same(out["d"]["c"], np.array([0.0, 0.0, 0.5]))
    assert same(out["_d"], np.array([False, False, True]))


@pytest.mark.parametrize(
    "mode,extra",
    [
        ("NextStep", {"action_level": "velocity", "obs_noise": 0.3}),  # per-world generators
        ("SameStep", {"action_level": "control"}),  # final_obs and final_info merged
        ("Disabled", {"action_level": "behavior"}),  # masked resets of one worker's worlds
    ],
)
def test_workers_return_what_one_process_returns(mode, extra):
    """5 worlds over 2 workers (3 + 2) against one FluidsVectorEnv of 5: everything reset and
    step return, labels, snapshots, through terminations, truncations and autoresets."""
    n, limit = 5, 7
    kwargs = {**SMALL, "max_episode_steps": limit, "autoreset_mode": mode, **extra}
    one = make_vec(n, **kwargs)
    two = make_vec(n, 2, **kwargs)
    assert isinstance(one, FluidsVectorEnv) and isinstance(two, FluidsWorkerVectorEnv)
    assert two.starts == [0, 3, 5]
    for attr in ("single_action_space", "single_observation_space", "action_space"):
        assert getattr(one, attr) == getattr(two, attr)
    assert one.observation_space == two.observation_space
    assert one.metadata == two.metadata
    assert same(one.reset(seed=30), two.reset(seed=30))
    one.action_space.seed(2)
    ended = 0
    for t in range(3 * limit):
        actions = one.action_space.sample() if t % 3 == 0 else one.supervisor_action()
        out = one.step(actions)
        assert same(out, two.step(actions)), t
        assert same(one.supervisor_action(), two.supervisor_action())
        done = out[2] | out[3]
        ended += int(done.sum())
        if mode == "Disabled" and done.any():
            mask = done.copy()
            mask[:3] = False  # only the second worker's worlds, when they ended
            if mask.any():
                options = {"reset_mask": mask}
                assert same(one.reset(options=dict(options)), two.reset(options=dict(options)))
            options = {"reset_mask": done & ~mask}
            if options["reset_mask"].any():
                assert same(one.reset(options=dict(options)), two.reset(options=dict(options)))
    assert ended >= n
    # world 4's snapshots continue alike (their pickles may differ in memo layout, not state)
    scalars = [gym.make("FLUIDS-v1", **extra, **SMALL, max_episode_steps=limit) for _ in "ab"]
    for env, vec in zip(scalars, (one, two), strict=True):
        env.reset(seed=0)
        snapshots.restore(env, vec.snapshot(4))
    for _ in range(3):
        action = scalars[0].unwrapped.supervisor_action()
        assert same(scalars[0].step(action), scalars[1].step(action))
    one.close()
    two.close()


def test_snapshots_restore_into_the_worker_that_holds_the_world():
    kwargs = {**SMALL, "action_level": "velocity", "max_episode_steps": 30}
    vec = make_vec(4, 2, **kwargs)
    vec.reset(seed=8)
    scalar = gym.make("FLUIDS-v1", **kwargs)
    scalar.reset(seed=50)
    for _ in range(4):
        scalar.step(np.array([5.0], np.float32))
    vec.restore(3, snapshots.snapshot(scalar))  # world 3: the second worker's second world
    actions = np.full((4, 1), 4.0, np.float32)
    for _ in range(6):
        obs, rewards, terminated, truncated, info = vec.step(actions)
        o, r, term, trunc, inf = scalar.step(actions[3])
        assert (
            same(obs[3], o) and rewards[3] == r and (terminated[3], truncated[3]) == (term, trunc)
        )
        assert same(info["supervisor_action"][3], inf["supervisor_action"])
    other = gym.make("FLUIDS-v1", **kwargs)  # and world 3's snapshot continues there alike
    other.reset(seed=0)
    snapshots.restore(other, vec.snapshot(3))
    assert same(other.step(actions[3]), scalar.step(actions[3]))
    with pytest.raises(ValueError, match="'index'"):
        vec.snapshot(4)
    vec.close()


def test_call_and_attributes_reach_every_world():
    vec = make_vec(3, 2, env_id="FLUIDS-v0", **SMALL)
    one = make_vec(3, env_id="FLUIDS-v0", **SMALL)
    vec.reset(seed=1)
    one.reset(seed=1)
    assert same(vec.call("supervisor_action"), one.call("supervisor_action"))
    assert vec.get_attr("action_level") == ("control",) * 3
    vec.set_attr("marker", [1, 2, 3])
    assert vec.get_attr("marker") == (1, 2, 3)
    vec.set_attr("marker", 7)
    assert vec.get_attr("marker") == (7, 7, 7)
    with pytest.raises(ValueError, match="'values'"):
        vec.set_attr("marker", [1, 2])
    vec.close()


@pytest.mark.parametrize(
    "kwargs,error,match",
    [
        ({"num_workers": 0}, ValueError, "'num_workers'"),
        ({"num_workers": 1.5}, ValueError, "'num_workers'"),
        ({"num_workers": 4}, ValueError, r"'num_workers' is 4; allowed: an integer in \[1, 3\]"),
        ({"num_workers": 2, "context": "teleport"}, ValueError, "'context'"),
        ({"num_workers": 1, "context": "teleport"}, ValueError, "'context'"),
        ({"num_workrs": 2}, ValueError, "unknown argument.*'num_workrs'.*'num_workers'"),
        # the scalar env's own checks, raised in a worker, reach the caller as they are
        ({"num_workers": 2, "num_cars": -1}, ValueError, "'num_cars'"),
        ({"num_workers": 2, "action_levle": "x"}, ValueError, "unknown argument.*'action_levle'"),
    ],
)
def test_bad_arguments_are_clear_errors(kwargs, error, match):
    with pytest.raises(error, match=match):
        gym.make_vec("FLUIDS-v1", 3, vectorization_mode="vector_entry_point", **kwargs)


def test_bad_actions_are_refused_before_any_world_moves():
    vec = make_vec(3, 2, **SMALL, action_level="velocity")
    one = make_vec(3, **SMALL, action_level="velocity")
    with pytest.raises(RuntimeError, match="before reset"):
        vec.step(np.zeros((3, 1), np.float32))
    assert same(vec.reset(seed=4), one.reset(seed=4))
    for bad, match in [
        (np.zeros((2, 1), np.float32), r"shape \(2, 1\).*\(3, 1\)"),
        (np.array([[1.0], [2.0], [np.nan]]), r"actions\[2\].*not finite"),
    ]:
        with pytest.raises(ValueError, match=match):
            vec.step(bad)
    good = one.supervisor_action()
    assert same(vec.step(good), one.step(good))
    vec.close()


def test_close_stops_the_workers_and_a_dead_worker_is_named():
    vec = make_vec(2, 2, **SMALL)
    vec.reset(seed=0)
    processes = list(vec._processes.values())  # slice 0 is this process's, slice 1 a worker's
    os.kill(processes[0].pid, signal.SIGKILL)
    processes[0].join()
    with pytest.raises(RuntimeError, match="worker 1"):
        vec.step(vec.action_space.sample())
    vec.close()
    assert not any(p.is_alive() for p in processes)
    with pytest.raises(RuntimeError, match="closed"):
        vec.supervisor_action()


def test_spawned_workers_import_the_package_themselves():
    """A ``spawn`` start (no fork of this process) gives the same worlds."""
    vec = make_vec(2, 2, context="spawn", **SMALL, action_level="velocity")
    one = make_vec(2, **SMALL, action_level="velocity")
    assert same(vec.reset(seed=6), one.reset(seed=6))
    actions = one.supervisor_action()
    assert same(vec.step(actions), one.step(actions))
    vec.close()


def test_frames_come_from_every_worker():
    vec = make_vec(3, 2, env_id="FLUIDS-v0", **SMALL, render_mode="rgb_array")
    one = make_vec(3, env_id="FLUIDS-v0", **SMALL, render_mode="rgb_array")
    vec.reset(seed=2)
    one.reset(seed=2)
    frames = vec.render()
    assert len(frames) == 3 and frames[2].ndim == 3 and frames[2].dtype == np.uint8
    assert same(frames, one.render())
    vec.close()


def test_an_interrupted_step_leaves_the_env_refusing_until_closed(monkeypatch):
    """Ctrl-C during a step (here in this process's slice, after the worker got its actions)
    leaves the worker's answer unread: later calls must refuse rather than read it."""
    vec = make_vec(4, 2, **SMALL, action_level="velocity")
    vec.reset(seed=3)
    local = vec._pipes[0].env

    def interrupted(actions):
        raise KeyboardInterrupt

    monkeypatch.setattr(local, "step", interrupted)
    with pytest.raises(KeyboardInterrupt):
        vec.step(np.zeros((4, 1), np.float32))
    monkeypatch.undo()
    with pytest.raises(RuntimeError, match="interrupted"):
        vec.step(np.zeros((4, 1), np.float32))
    processes = list(vec._processes.values())
    vec.close()
    assert not any(p.is_alive() for p in processes)


@pytest.mark.parametrize("context", ["fork", "spawn"])
def test_a_worker_that_stops_answering_is_named_after_the_timeout(context):
    vec = make_vec(3, 2, context=context, worker_timeout=300.0, **SMALL)
    vec.reset(seed=0)
    vec.step(vec.action_space.sample())  # a spawned worker has loaded its kernels now
    vec.worker_timeout = 2.0
    worker = vec._processes[1]
    os.kill(worker.pid, signal.SIGSTOP)
    try:
        with pytest.raises(RuntimeError, match=r"worker 1 \(pid \d+, stopped\) has not answered"):
            vec.step(vec.action_space.sample())
        with pytest.raises(RuntimeError, match="close"):  # the slices may be a step apart now
            vec.supervisor_action()
    finally:
        vec.close()  # a stopped worker is killed, not waited for
    assert not worker.is_alive()


def test_too_many_worlds_are_refused_before_any_is_built():
    for workers in (1, 2):
        with pytest.raises(ValueError, match=r"field 'num_envs' is 1000000000; allowed: an integ"):
            make_vec(10**9, workers, **SMALL)


@pytest.mark.parametrize("value", [0, -1.0, float("nan"), float("inf"), "5", True])
def test_a_bad_worker_timeout_is_refused_by_name(value):
    with pytest.raises(ValueError, match="field 'worker_timeout'"):
        make_vec(2, 2, worker_timeout=value, **SMALL)


def test_the_world_bound_follows_the_memory():
    assert max_num_envs(10 * WORLD_BYTES + 1) == 10
    assert max_num_envs(0) is None  # unknown memory: no bound
    assert max_num_envs() >= 1000  # these machines hold thousands of worlds
