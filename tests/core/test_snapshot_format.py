"""The safe snapshot format (issue #44): versioned, plain data, checked field by field.

Registry-driven: on every Gymnasium id a snapshot's bytes restore into an env that was never
reset, whose next step passes Gymnasium's checker and equals the original's; on every
PettingZoo id the same without the wrappers. Then each kind of damage is refused with a clear
`ValueError` naming what is wrong (the fuzz tests in `test_snapshot_fuzz.py` cover them all on
every id).
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from exact_compare import exactly_equal
from snapshot_mutations import array_fields, field_pairs, object_nodes, repack

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core import snapshot as snap
from fluids_bench.core.snapshot import EnvSnapshot, WrappedSnapshot
from fluids_bench.core.state_format import StateFormatError, unpack
from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS, make_parallel_env

GYM_IDS = sorted(ENV_SPECS)
SEED = 3


def _driven(env_id: str, steps: int = 3) -> gym.Env:
    env = gym.make(env_id)
    env.reset(seed=SEED)
    env.action_space.seed(SEED)
    for _ in range(steps):
        if env.step(env.action_space.sample())[2]:
            env.reset(seed=SEED + 1)
    return env


@pytest.mark.parametrize("env_id", GYM_IDS)
def test_restore_into_a_never_reset_env_passes_the_checker_and_continues_exactly(env_id):
    env = _driven(env_id, 1 if env_id.startswith("DAG") else 3)
    data = snap.snapshot(env).to_bytes()
    assert isinstance(data, bytes) and data[:2] == b"PK"  # an .npz (zip) archive
    fresh = gym.make(env_id)  # never reset
    snap.restore(fresh, data)
    action = env.action_space.sample()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # Gymnasium's passive checker warns on any problem
        theirs = fresh.step(action)
    assert exactly_equal(list(env.step(action)), list(theirs))


@pytest.mark.parametrize("env_id", sorted(PARALLEL_ENV_SPECS))
def test_parallel_restore_into_a_never_reset_env(env_id):
    env = make_parallel_env(env_id)
    env.reset(seed=SEED)
    data = env.snapshot().to_bytes()
    fresh = make_parallel_env(env_id)
    fresh.restore(data)
    actions = {a: env.action_space(a).sample() for a in env.agents}
    assert exactly_equal(list(env.step(actions)), list(fresh.step(actions)))


def test_header_is_versioned():
    env = _driven("GridWorld-v0")
    saved = env.unwrapped.snapshot()
    meta, arrays = unpack(saved.to_bytes())
    assert meta["format"] == "fluids-bench-state"
    assert meta["format_version"] == snap.FORMAT_VERSION
    assert meta["package_version"] == fluids_bench.__version__
    assert meta["env_id"] == "GridWorld-v0"
    assert meta["kwargs_hash"] == snap.kwargs_hash(saved.kwargs)
    assert all(a.dtype != object for a in arrays)
    assert EnvSnapshot.from_bytes(saved.to_bytes()) == saved
    wrapped = snap.snapshot(env)
    assert WrappedSnapshot.from_bytes(wrapped.to_bytes()) == wrapped


def _refused(env_id: str, data: bytes, match: str) -> None:
    target = gym.make(env_id)
    with pytest.raises(ValueError, match=match):
        target.unwrapped.restore(data)


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda m, a: None, None),
        (lambda m, a: m.update(package_version="0.0.1"), "written by fluids-bench 0.0.1"),
        (lambda m, a: m.update(format_version=2), "format version 2"),
        (lambda m, a: m.update(env_id="DAG-v0"), "id 'DAG-v0'"),
        (lambda m, a: m.update(kwargs_hash="0" * 16), "kwargs hash"),
        (lambda m, a: m["fields"]["dict"].pop(), r"missing field\(s\) \['_state'\]"),
        (lambda m, a: m["fields"]["dict"].append(["x", 1]), r"unexpected field\(s\) \['x'\]"),
        (lambda m, a: m["fields"].update(dict=[]), "missing field"),
        (lambda m, a: m["fields"]["dict"][-1].__setitem__(1, {"pickle": "x"}), "tag 'pickle'"),
        (
            lambda m, a: m["fields"]["dict"][-1].__setitem__(1, {"object": ["os:system", {}]}),
            "class os:system is not allowed",
        ),
        (lambda m, a: a.append(np.zeros(3)), "belong to no field"),
    ],
)
def test_damage_is_refused_with_a_clear_error(edit, match):
    saved = _driven("GridWorld-v0").unwrapped.snapshot()
    data = repack(saved, edit)
    if match is None:  # the repacking itself changes nothing
        target = gym.make("GridWorld-v0")
        target.unwrapped.restore(data)
        return
    _refused("GridWorld-v0", data, match)


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (b"", "empty"),
        (b"PK\x03\x04garbage", "damaged or not a fluids-bench state"),
        (b"\x80\x04\x95 a pickle", "damaged or not a fluids-bench state"),
    ],
)
def test_bytes_that_are_not_a_snapshot_are_refused(data, match):
    _refused("GridWorld-v0", data, match)
    with pytest.raises(ValueError, match=match):
        WrappedSnapshot.from_bytes(data)


def test_truncated_snapshots_are_refused():
    data = _driven("GridWorld-v0").unwrapped.snapshot().to_bytes()
    for cut in range(0, len(data), max(1, len(data) // 40)):
        _refused("GridWorld-v0", data[:cut], "snapshot")


def test_nested_fields_are_checked():
    """A missing or extra field inside an object of the state, an array of another dtype or
    shape: each refused, naming the field."""
    saved = _driven("DrivingTrack-v0", 2).unwrapped.snapshot()
    meta, _ = unpack(saved.to_bytes())
    nodes = [(p, n) for p, n in object_nodes(meta["fields"]) if field_pairs(n)]
    index = next(i for i, (p, n) in enumerate(nodes) if array_fields(n))
    name = field_pairs(nodes[index][1])[0][0]

    def pairs(m):
        return field_pairs([n for _, n in object_nodes(m["fields"]) if field_pairs(n)][index])

    missing = repack(saved, lambda m, a: pairs(m).pop(0))
    _refused("DrivingTrack-v0", missing, rf"missing field\(s\) \['{name}'\]")
    extra = repack(saved, lambda m, a: pairs(m).append(["bogus", 1]))
    _refused("DrivingTrack-v0", extra, r"unexpected field\(s\) \['bogus'\]")
    key, entry = array_fields(nodes[index][1])[0]
    retyped = repack(saved, lambda m, a: a.__setitem__(entry, a[entry].astype(np.int16)))
    _refused("DrivingTrack-v0", retyped, f"{key}: an array of dtype int16")
    reshaped = repack(saved, lambda m, a: a.__setitem__(entry, a[entry][..., None]))
    _refused("DrivingTrack-v0", reshaped, f"{key}: an array of dtype")


def test_a_refused_restore_leaves_the_env_as_it_was():
    env = _driven("GridWorld-v0")
    before = env.unwrapped.snapshot()
    other = _driven("GridWorld-v0", 6).unwrapped.snapshot()
    damaged = repack(other, lambda m, a: m["fields"]["dict"].append(["x", 1]))
    with pytest.raises(StateFormatError):
        env.unwrapped.restore(damaged)
    assert env.unwrapped.snapshot() == before


def test_restore_refuses_other_wrappers_and_bad_counters():
    env = _driven("GridWorld-v0")
    saved = snap.snapshot(env)
    bad = WrappedSnapshot(saved.env, (("TimeLimit", {"_elapsed_steps": "3"}),) + saved.wrappers[1:])
    with pytest.raises(ValueError, match="not a count"):
        snap.restore(gym.make("GridWorld-v0"), bad.to_bytes())
    with pytest.raises(ValueError, match="wrapped in"):
        snap.restore(gym.make("GridWorld-v0").env, saved)
