"""Minari export: real datasets on disk, round trips, env recovery, atomicity, the CLI."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import gymnasium as gym
import minari
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from minari.dataset._storages.arrow_storage import ArrowStorage

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.dataset import Trajectory
from fluids_bench.commands import collect as collect_command
from fluids_bench.data.collect import ActorSpec, collect
from fluids_bench.data.minari_export import (
    EXECUTED_KEY,
    PROVENANCE_KEY,
    STAGING_DIR,
    check_dataset_id,
    export_minari,
)
from fluids_bench.registration import ENV_SPECS

IDS = sorted(ENV_SPECS)
METADATA = dict(
    algorithm_name="test",
    description="test data",
    author="tester",
    author_email="tester@example.org",
    code_permalink="https://example.org/code",
)


@pytest.fixture(autouse=True)
def minari_root(tmp_path, monkeypatch) -> Path:
    root = tmp_path / "datasets"
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))
    return root


def _noisy(env_id: str) -> ActorSpec:
    discrete = isinstance(gym.make(env_id).action_space, gym.spaces.Discrete)
    return ActorSpec("noise", epsilon=0.3) if discrete else ActorSpec("noise", noise_std=0.3)


def _assert_round_trip(dataset, trajectories, provenance: str) -> None:
    assert dataset.total_episodes == len(trajectories)
    assert dataset.total_steps == sum(len(t) for t in trajectories)
    episodes = list(dataset.iterate_episodes())
    seeds = [m["seed"] for m in dataset.storage.get_episode_metadata(range(len(trajectories)))]
    assert seeds == [t.seed for t in trajectories]
    for episode, t in zip(episodes, trajectories, strict=True):
        if isinstance(episode.observations, dict):  # Dict space: rollouts keep a list of dicts
            for key, values in episode.observations.items():
                expected = np.stack([row[key] for row in t.observations])
                np.testing.assert_array_equal(values, expected)
                assert values.dtype == expected.dtype
        else:
            np.testing.assert_array_equal(episode.observations, t.observations)
            assert episode.observations.dtype == t.observations.dtype
        np.testing.assert_array_equal(episode.actions, t.labels)  # actions are the labels
        np.testing.assert_array_equal(episode.rewards, t.rewards)
        ends = np.zeros(len(t), dtype=bool)
        ends[-1] = True
        np.testing.assert_array_equal(episode.terminations, ends & t.terminated)
        np.testing.assert_array_equal(episode.truncations, ends & (not t.terminated))
        executed = np.asarray(episode.infos[EXECUTED_KEY])
        assert len(executed) == len(t) + 1  # Minari's T + 1 info rows, the reset's first
        np.testing.assert_array_equal(executed[1:].reshape(t.actions.shape), t.actions)
        assert list(episode.infos[PROVENANCE_KEY]) == ["reset"] + [provenance] * len(t)


@pytest.mark.parametrize("env_id", IDS)
def test_round_trip_for_every_registered_env(env_id):
    trajectories = collect(env_id, 2, actor=_noisy(env_id), seed=4, max_steps=15, progress=False)
    dataset_id = f"tests/{env_id.lower()}-v0"
    export_minari(dataset_id, trajectories, env_id=env_id, provenance="noise", **METADATA)
    dataset = minari.load_dataset(dataset_id)
    _assert_round_trip(dataset, trajectories, "noise")
    recovered = dataset.recover_environment()
    assert recovered.spec == gym.make(env_id).spec
    first, _ = recovered.reset(seed=trajectories[0].seed)
    np.testing.assert_array_equal(first, trajectories[0].observations[0])
    meta = dataset.storage.metadata
    assert meta["algorithm_name"] == "test" and meta["author"] == {"tester"}
    assert "ref_min_score" not in meta and "ref_max_score" not in meta


@st.composite
def _dag_trajectories(draw) -> list[Trajectory]:
    """Arbitrary trajectories in DAG-v0's spaces (Box(0, 3, (2,)) observations, Discrete(2))."""
    out = []
    for seed in range(draw(st.integers(1, 3))):
        steps = draw(st.integers(1, 6))
        cell = st.floats(0.0, 3.0, width=32)
        observations = np.array(
            draw(st.lists(cell, min_size=2 * steps + 2, max_size=2 * steps + 2)), dtype=np.float32
        ).reshape(steps + 1, 2)
        actions = st.lists(st.integers(0, 1), min_size=steps, max_size=steps)
        rewards = st.lists(st.floats(-1e6, 1e6), min_size=steps, max_size=steps)
        out.append(
            Trajectory(
                observations=observations,
                actions=np.array(draw(actions), dtype=np.int64),
                labels=np.array(draw(actions), dtype=np.int64),
                rewards=np.array(draw(rewards), dtype=np.float64),
                infos=[{}] * (steps + 1),
                terminated=draw(st.booleans()),
                truncated=False,
                seed=seed,
            )
        )
    return out


@settings(
    max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    trajectories=_dag_trajectories(), provenance=st.sampled_from(["supervisor", "noise", "learner"])
)
def test_round_trip_property(trajectories, provenance):
    dataset = export_minari(
        "prop/dag-v0",
        trajectories,
        env_id="DAG-v0",
        provenance=provenance,
        overwrite=True,
        **METADATA,
    )
    _assert_round_trip(dataset, trajectories, provenance)


def test_env_kwargs_are_recovered_and_reference_scores_stored():
    kwargs = {"action_level": "velocity", "num_cars": 2, "num_pedestrians": 1, "obs_noise": 0.01}
    trajectories = collect("FLUIDS-v0", 2, env_kwargs=kwargs, max_steps=20, progress=False)
    dataset = export_minari(
        "fluids/velocity-v1",
        trajectories,
        env_id="FLUIDS-v0",
        env_kwargs=kwargs,
        ref_min_score=-1.0,
        ref_max_score=1.0,
        **METADATA,
    )
    _assert_round_trip(dataset, trajectories, "supervisor")
    env = dataset.recover_environment()
    assert {k: env.spec.kwargs[k] for k in kwargs} == kwargs
    assert env.unwrapped.action_level == "velocity" and env.unwrapped.world.n == 3 + 1
    assert dataset.storage.metadata["ref_min_score"] == -1.0
    assert dataset.storage.metadata["ref_max_score"] == 1.0
    with pytest.raises(ValueError, match="both ref_min_score and ref_max_score"):
        export_minari(
            "fluids/other-v0",
            trajectories,
            env_id="FLUIDS-v0",
            env_kwargs=kwargs,
            ref_max_score=1.0,
        )


def test_dict_observations_with_images_round_trip_exactly():
    kwargs = {"obs_type": ["explicit", "qlidar", "birdseye"], "birdseye_size": 64}
    trajectories = collect("FLUIDS-v0", 2, env_kwargs=kwargs, max_steps=8, progress=False)
    dataset = export_minari(
        "fluids/dict-v0", trajectories, env_id="FLUIDS-v0", env_kwargs=kwargs, **METADATA
    )
    _assert_round_trip(dataset, trajectories, "supervisor")
    assert set(dataset.observation_space.spaces) == {"explicit", "qlidar", "birdseye"}


def test_existing_dataset_is_refused_unless_overwrite(minari_root):
    first = collect("DAG-v0", 2, progress=False)
    second = collect("DAG-v0", 3, seed=10, progress=False)
    export_minari("tests/dag-v0", first, env_id="DAG-v0", **METADATA)
    with pytest.raises(FileExistsError, match="overwrite"):
        export_minari("tests/dag-v0", second, env_id="DAG-v0", **METADATA)
    assert minari.load_dataset("tests/dag-v0").total_episodes == 2
    export_minari("tests/dag-v0", second, env_id="DAG-v0", overwrite=True, **METADATA)
    _assert_round_trip(minari.load_dataset("tests/dag-v0"), second, "supervisor")
    assert list(minari.list_local_datasets()) == ["tests/dag-v0"]
    assert not (minari_root / STAGING_DIR).exists()


def test_an_interrupted_export_leaves_no_dataset(minari_root, monkeypatch):
    trajectories = collect("GridWorld-v0", 3, progress=False)
    export_minari("tests/grid-v0", trajectories[:1], env_id="GridWorld-v0", **METADATA)
    original = ArrowStorage.update_episodes

    def interrupted(self, episodes):
        original(self, list(episodes)[:1])  # one episode reaches the disk, then ^C
        raise KeyboardInterrupt

    monkeypatch.setattr(ArrowStorage, "update_episodes", interrupted)
    for dataset_id, overwrite in (("tests/grid-v1", False), ("tests/grid-v0", True)):
        with pytest.raises(KeyboardInterrupt):
            export_minari(
                dataset_id, trajectories, env_id="GridWorld-v0", overwrite=overwrite, **METADATA
            )
    assert not (minari_root / "tests" / "grid-v1").exists()
    assert list(minari.list_local_datasets()) == ["tests/grid-v0"]
    assert minari.load_dataset("tests/grid-v0").total_episodes == 1  # the old one is intact
    assert not (minari_root / STAGING_DIR).exists()


def test_malformed_ids_are_refused_before_writing(minari_root):
    trajectories = collect("DAG-v0", 1, progress=False)
    for bad in ("no-version", "x/name-v0", "spaces are bad-v0", "tests/dag-vX"):
        with pytest.raises(ValueError, match="dataset id"):
            export_minari(bad, trajectories, env_id="DAG-v0")
    assert check_dataset_id("fluids/nested/name-v3") == ("fluids/nested", "name", 3)
    assert not minari_root.exists() or not any(minari_root.rglob("data"))


@pytest.mark.parametrize(
    "dataset_id",
    ["fluids/velocity-v0", "a/b/c-v12", "name-v3", "name", "x/name-v0", "ab/-v0", "a b-v0",
     "ns/na-me_2-v1", "ns//x-v0", "-v0", "ns/x-v", "/x-v0", "ns/x-v0/"],
)  # fmt: skip
def test_dataset_id_rule_is_minaris(dataset_id):
    """Minari keeps its id rule private; ours must accept exactly the versioned ids Minari
    parses, with the same parts (this fails if a Minari release changes the rule)."""
    from minari.dataset.minari_dataset import parse_dataset_id

    try:
        theirs = parse_dataset_id(dataset_id)
    except (ValueError, TypeError):  # TypeError: Minari's answer to a missing version
        theirs = None
    try:
        ours = check_dataset_id(dataset_id)
    except ValueError:
        ours = None
    assert ours == theirs


def _cli(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="fluids-bench")
    collect_command.add_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.func(args)


def test_cli_collects_a_noisy_dataset(capsys):
    argv = [
        "collect",
        "--env",
        "GridWorld-v0",
        "--episodes",
        "3",
        "--dataset",
        "cli/grid-v0",
        "--noise",
        "0.4",
        "--workers",
        "2",
        "--no-progress",
        "--author-email",
        "a@b.org",
        "--code-permalink",
        "https://example.org",
    ]
    assert _cli(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["episodes"] == 3 and summary["provenance"] == "noise"
    dataset = minari.load_dataset("cli/grid-v0")
    expected = collect("GridWorld-v0", 3, actor=ActorSpec("noise", epsilon=0.4), progress=False)
    _assert_round_trip(dataset, expected, "noise")
    assert "noise-injected" in dataset.storage.metadata["algorithm_name"]
    with pytest.raises(FileExistsError):
        _cli(argv)
    assert _cli([*argv, "--overwrite", "--seed", "7"]) == 0
    assert (
        minari.load_dataset("cli/grid-v0").storage.get_episode_metadata([0]).__next__()["seed"] == 7
    )


def test_cli_through_the_main_entry_point(capsys):
    from fluids_bench.cli import main

    code = main(
        [
            "collect",
            "--env",
            "DAG-v0",
            "--episodes",
            "2",
            "--dataset",
            "cli/dag-v0",
            "--no-progress",
        ]
    )
    assert code == 0 and json.loads(capsys.readouterr().out)["steps"] == 6
    assert main(["collect", "--env", "DAG-v0", "--episodes", "2", "--dataset", "cli/dag-v0"]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["collect", "--env", "DAG-v0", "--episodes", "1", "--dataset", "bad id"]) == 2
