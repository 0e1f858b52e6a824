"""Fuzz tests of the snapshot format (issue #44): damaged states on every registered id.

Every damage of `snapshot_mutations.mutations` (empty, truncated, garbled bytes; a missing or
extra field at the top or in any object; an array of another dtype or rank; another id,
kwargs, format or package version) must be refused with a `ValueError` that says what is wrong,
and leave the target env as it was; garbled bytes that happen to hit nothing that matters
(a zip timestamp) must restore the very same state. A sample of ids runs in every test run;
all ids with `FLUIDS_BENCH_FULL_FUZZ=1` (the `fuzz_full` marker; `tests/test_fuzz.py` gives the
command)
"""

from __future__ import annotations

import gymnasium as gym
import pytest
from snapshot_mutations import mutations

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core.state_format import StateFormatError
from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS, make_parallel_env

SAMPLE = ["GridWorld-v0", "DrivingTrack-v0", "FLUIDS-v1", "FLUIDS-MultiAgent-v1"]
ALL = sorted(ENV_SPECS) + sorted(PARALLEL_ENV_SPECS)
SEED = 7


def _env(env_id: str):
    """The unwrapped env of `env_id` after a few seeded steps."""
    if env_id in PARALLEL_ENV_SPECS:
        env = make_parallel_env(env_id)
        env.reset(seed=SEED)
        for agent in env.possible_agents:
            env.action_space(agent).seed(SEED)
        for _ in range(3):
            if env.agents:
                env.step({a: env.action_space(a).sample() for a in env.agents})
        return env
    env = gym.make(env_id)
    env.reset(seed=SEED)
    env.action_space.seed(SEED)
    for _ in range(1 if env_id.startswith("DAG") else 3):
        env.step(env.action_space.sample())
    return env.unwrapped


def _new(env_id: str):
    if env_id in PARALLEL_ENV_SPECS:
        return make_parallel_env(env_id)
    return gym.make(env_id).unwrapped


def _fuzz(env_id: str) -> None:
    source = _env(env_id)
    saved = source.snapshot()
    target = _new(env_id)  # never reset
    target.reset(seed=SEED + 1)
    before = target.snapshot()
    accepted = []
    for what, data in mutations(saved):
        try:
            target.restore(data)
        except StateFormatError as error:
            message = str(error)
            assert message and ("restore" in message or "snapshot" in message), (what, message)
            assert target.snapshot() == before, f"{env_id}: refusing {what} changed the env"
            continue
        accepted.append(what)
        assert what.startswith("garbled"), f"{env_id}: {what} was accepted"
        assert target.snapshot() == saved, f"{env_id}: {what} restored another state"
        target.restore(before)
    assert len(accepted) <= 2, f"{env_id}: garbled bytes accepted {len(accepted)} times"


@pytest.mark.parametrize("env_id", SAMPLE)
def test_damaged_snapshots_are_refused_sample(env_id):
    _fuzz(env_id)


@pytest.mark.fuzz_full
@pytest.mark.parametrize("env_id", [i for i in ALL if i not in SAMPLE])
def test_damaged_snapshots_are_refused_every_id(env_id):
    _fuzz(env_id)
