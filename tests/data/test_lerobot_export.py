"""``fluids-bench export --to lerobot`` writes a structurally valid LeRobotDataset (v3.0 layout)
from a ``collect`` dataset: the files and tables LeRobot's loader reads, features with the
declared dtypes and shapes, the supervisor's labels as ``action``, and image observations as
mp4 videos that decode to the observed frames exactly. Loading with the real ``lerobot`` is
``scripts/clients/lerobot_roundtrip.py`` (its own environment)."""

from __future__ import annotations

import json

import imageio.v3 as iio
import minari
import numpy as np
import pyarrow.parquet as pq
import pytest

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.cli import main
from fluids_bench.data.lerobot_export import export_lerobot


@pytest.fixture(autouse=True)
def minari_root(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "datasets"))


def _collect(env_id: str, name: str, *kwargs: str, steps: int = 8) -> minari.MinariDataset:
    extra = [a for k in kwargs for a in ("--env-kwarg", k)]
    argv = ["collect", "--env", env_id, "--episodes", "2", "--dataset", name, "--seed", "5"]
    assert main([*argv, "--max-steps", str(steps), "--no-progress", *extra]) == 0
    return minari.load_dataset(name)


def _check_layout(out, dataset):
    info = json.loads((out / "meta/info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["total_episodes"] == 2
    assert info["total_frames"] == dataset.total_steps and info["total_tasks"] == 1
    frames = pq.read_table(out / "data/chunk-000/file-000.parquet").to_pydict()
    episodes = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pydict()
    tasks = pq.read_table(out / "meta/tasks.parquet").to_pydict()
    assert tasks["task_index"] == [0] and tasks["__index_level_0__"] == [dataset.spec.env_spec.id]
    for name, feat in info["features"].items():
        if feat["dtype"] == "video":
            continue
        column = np.asarray(frames[name])
        assert column.shape[0] == info["total_frames"]
        assert list(column.shape[1:]) == ([] if feat["shape"] == [1] else feat["shape"]), name
    assert frames["index"] == list(range(info["total_frames"]))
    rows = 0
    for e, episode in enumerate(dataset.iterate_episodes()):
        n = len(episode.actions)
        assert episodes["length"][e] == n and episodes["episode_index"][e] == e
        assert (episodes["dataset_from_index"][e], episodes["dataset_to_index"][e]) == (
            rows,
            rows + n,
        )
        assert frames["episode_index"][rows : rows + n] == [e] * n
        assert frames["frame_index"][rows : rows + n] == list(range(n))
        np.testing.assert_allclose(frames["timestamp"][rows : rows + n], np.arange(n) / info["fps"])
        labels = np.asarray(frames["action"][rows : rows + n]).reshape(n, -1)
        assert np.array_equal(labels, np.asarray(episode.actions).reshape(n, -1))  # the labels
        assert frames["next.done"][rows + n - 1] and not any(
            frames["next.done"][rows : rows + n - 1]
        )
        rows += n
    return info, frames, episodes


def _check_stats(out, info, frames, images=None):
    """meta/stats.json: min, max, mean, std (ddof 0) and count of every feature, as LeRobot
    lays them out: the feature's shape (`[1]` for scalars), images per channel in [0, 1] as
    `(3, 1, 1)`; `images` maps a video feature to its frames."""
    stats = json.loads((out / "meta/stats.json").read_text())
    assert set(stats) == set(info["features"])
    for name, feat in info["features"].items():
        entry = stats[name]
        assert set(entry) == {"min", "max", "mean", "std", "count"}, name
        assert entry["count"] == [info["total_frames"]], name
        if feat["dtype"] == "video":
            x = np.concatenate(images[name]).reshape(-1, 3) / 255.0
            expected = {"min": x.min(0), "max": x.max(0), "mean": x.mean(0), "std": x.std(0)}
            for key, value in expected.items():
                assert np.asarray(entry[key]).shape == (3, 1, 1), (name, key)
                np.testing.assert_allclose(np.asarray(entry[key]).reshape(3), value, atol=1e-9)
            continue
        x = np.asarray(frames[name], np.float64).reshape(info["total_frames"], *feat["shape"])
        expected = {"min": x.min(0), "max": x.max(0), "mean": x.mean(0), "std": x.std(0)}
        for key, value in expected.items():
            assert list(np.shape(entry[key])) == feat["shape"], (name, key)
            np.testing.assert_allclose(entry[key], value, rtol=1e-12, atol=1e-12)
    return stats


def test_image_and_state_observations_export_as_video_and_columns(tmp_path):
    dataset = _collect("FLUIDS-v3", "tests/bev-v0", 'obs_type=["birdseye","explicit"]')
    out = tmp_path / "lerobot"
    assert main(["export", "--to", "lerobot", "tests/bev-v0", str(out)]) == 0
    info, frames, episodes = _check_layout(out, dataset)
    assert info["fps"] == 10  # FLUIDS' dt = 0.1 s
    video = info["features"]["observation.images.birdseye"]
    assert video["dtype"] == "video" and video["shape"] == [84, 84, 3]
    assert video["info"]["video.fps"] == 10 and video["info"]["video.channels"] == 3
    assert info["features"]["observation.explicit"]["shape"] == [69]
    rows = 0
    for e, episode in enumerate(dataset.iterate_episodes()):
        n = len(episode.actions)
        path = out / info["video_path"].format(
            video_key="observation.images.birdseye",
            chunk_index=episodes["videos/observation.images.birdseye/chunk_index"][e],
            file_index=episodes["videos/observation.images.birdseye/file_index"][e],
        )
        assert np.array_equal(iio.imread(path), episode.observations["birdseye"][:n])  # lossless
        state = np.asarray(frames["observation.explicit"][rows : rows + n], np.float32)
        assert np.array_equal(state, episode.observations["explicit"][:n])
        rows += n
    images = [e.observations["birdseye"][: len(e.actions)] for e in dataset.iterate_episodes()]
    stats = _check_stats(out, info, frames, {"observation.images.birdseye": images})
    assert 0.0 <= stats["observation.images.birdseye"]["mean"][0][0][0] <= 1.0


def test_discrete_actions_and_vector_states(tmp_path):
    dataset = _collect("GridWorld-v0", "tests/grid-v0", steps=6)
    export_lerobot(dataset, tmp_path / "out")
    info, frames, _ = _check_layout(tmp_path / "out", dataset)
    assert info["video_path"] is None and info["features"]["action"]["dtype"] == "int64"
    assert "observation.state" in info["features"]
    stats = _check_stats(tmp_path / "out", info, frames)
    assert stats["next.done"]["max"] == [1.0] and stats["index"]["min"] == [0.0]


def test_existing_output_is_refused_and_a_failed_export_leaves_nothing(tmp_path):
    dataset = _collect("GridWorld-v0", "tests/grid-v0", steps=3)
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(FileExistsError, match="exists"):
        export_lerobot(dataset, out)
    export_lerobot(dataset, out, overwrite=True)
    assert (out / "meta/info.json").exists()
    with pytest.raises(ValueError, match="fps is 0"):
        export_lerobot(dataset, tmp_path / "other", fps=0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["datasets", "out"]
