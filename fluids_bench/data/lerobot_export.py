"""A Minari dataset of the suite as a LeRobotDataset (LeRobot's v3.0 layout), without lerobot.

`export_lerobot(dataset, out)` writes, under `out`:

* `data/chunk-000/file-000.parquet`: one row per step `t` of every episode, with the
  observation of `observations[t]`, `action` = the supervisor's label for that state (the
  Minari dataset's `actions`), `next.reward`, `next.done`, `timestamp` (`t / fps`, s),
  `frame_index` (`t`), `episode_index`, `index` (global row) and `task_index` (0);
* `videos/<key>/chunk-CCC/file-EEE.mp4`: one video per image observation and episode
  (`EEE = episode % 1000`, `CCC = episode // 1000`), encoded losslessly (H.264 RGB,
  `libx264rgb -crf 0`), so decoded frames equal the observed ones;
* `meta/info.json` (codebase version, fps, paths, features with dtypes and shapes),
  `meta/tasks.parquet` (one task: the env id) and `meta/episodes/chunk-000/file-000.parquet`
  (per episode: length, row range, data and video file indices, video time range);
* `meta/stats.json`: every feature's min, max, mean, std and frame count, which LeRobot's
  policies normalise with ([`lerobot_stats`][fluids_bench.data.lerobot_stats]).

Observation keys follow LeRobot's names: a Box image (`uint8`, `(H, W, 3)`) is
`observation.image`, any other Box `observation.state`; a Dict observation's images are
`observation.images.<key>` and its other entries `observation.<key>`. A Discrete value is an
`int64` of shape `(1,)`. The final observation of each episode (after the last action) has
no label and is not exported. `fps` is the env's `render_fps` unless given.

Writing is atomic: everything is built in a hidden sibling folder, renamed into place at the
end. An existing `out` is refused unless `overwrite`.
"""

from __future__ import annotations

import json
import os
import shutil
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from gymnasium import spaces

from fluids_bench.data.lerobot_stats import STATS_PATH, ImageStats, array_stats

CODEBASE_VERSION = "v3.0"
CHUNK_SIZE = 1000  # files per chunk folder, as LeRobot's default
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
EPISODES_PATH = "meta/episodes/chunk-000/file-000.parquet"
VIDEO_INFO = {"video.codec": "h264", "video.pix_fmt": "rgb24", "video.is_depth_map": False}


def is_image(space: spaces.Space) -> bool:
    """A `uint8` Box of shape `(H, W, 3)`: stored as video."""
    return (
        isinstance(space, spaces.Box)
        and space.dtype == np.uint8
        and len(space.shape) == 3
        and space.shape[2] == 3
    )


def observation_keys(space: spaces.Space) -> dict[str, tuple[str | None, spaces.Space]]:
    """LeRobot feature name -> (the Dict key, or None for the whole observation; its space)."""
    if isinstance(space, spaces.Dict):
        out = {}
        for key, sub in space.spaces.items():
            name = f"observation.images.{key}" if is_image(sub) else f"observation.{key}"
            out[name] = (key, sub)
        return out
    return {"observation.image" if is_image(space) else "observation.state": (None, space)}


def feature(space: spaces.Space, where: str) -> dict[str, Any]:
    """The LeRobot feature entry (dtype, shape, names) of a Box or Discrete space."""
    if is_image(space):
        h, w, c = space.shape
        return {"dtype": "video", "shape": [h, w, c], "names": ["height", "width", "channels"]}
    if isinstance(space, spaces.Discrete):
        return {"dtype": "int64", "shape": [1], "names": None}
    if isinstance(space, spaces.Box):
        return {"dtype": str(space.dtype), "shape": list(space.shape), "names": None}
    raise ValueError(
        f"export --to lerobot: {where} has space {space}; allowed: Box, Discrete, or a Dict of them"
    )


def _column(values: np.ndarray, feat: dict[str, Any]) -> pa.Array:
    """Rows of one feature as an Arrow column LeRobot reads (scalars flat, arrays as lists)."""
    values = np.asarray(values, dtype=feat["dtype"])
    if feat["shape"] == [1]:
        return pa.array(values.reshape(-1))
    shape = feat["shape"]
    flat = pa.array(values.reshape(-1))
    for size in reversed(shape):
        flat = pa.FixedSizeListArray.from_arrays(flat, size)
    return flat


def _write_video(path: Path, frames: np.ndarray, fps: int) -> None:
    import imageio.v2 as imageio  # imageio-ffmpeg ships the ffmpeg binary

    path.parent.mkdir(parents=True, exist_ok=True)
    writer = imageio.get_writer(
        path,
        fps=fps,
        codec="libx264rgb",
        pixelformat="rgb24",
        macro_block_size=1,
        ffmpeg_params=["-crf", "0", "-g", "2"],
        ffmpeg_log_level="error",
    )
    try:
        for frame in frames:
            writer.append_data(np.ascontiguousarray(frame))
    finally:
        writer.close()


def _episodes(dataset: Any) -> Iterator[Any]:
    for episode_id in sorted(dataset.episode_indices):
        yield from dataset.iterate_episodes([int(episode_id)])


def _fps(env_id: str) -> int:
    import gymnasium as gym
    from gymnasium.envs.registration import load_env_creator

    creator = load_env_creator(gym.spec(env_id).entry_point)
    fps = getattr(creator, "metadata", {}).get("render_fps")
    if not fps:
        raise ValueError(f"export --to lerobot: {env_id} declares no render_fps; pass fps")
    return round(fps)


def export_lerobot(
    dataset: Any, out: str | os.PathLike, *, fps: int | None = None, overwrite: bool = False
) -> dict[str, Any]:
    """Write `dataset` (a `minari.MinariDataset`, or a dataset id to load) as a
    LeRobotDataset under `out`; returns its `meta/info.json` content.

    Raises:
        FileExistsError: `out` exists and `overwrite` is false.
        ValueError: a space the format cannot hold (Box and Discrete only, or a Dict of them),
            or no `fps` known.
    """
    if isinstance(dataset, str):
        import minari

        dataset = minari.load_dataset(dataset)
    out = Path(out)
    if out.exists() and not overwrite:
        raise FileExistsError(f"export --to lerobot: {out} exists (pass overwrite to replace it)")
    env_id = dataset.spec.env_spec.id if dataset.spec.env_spec is not None else None
    if fps is None:
        if env_id is None:
            raise ValueError("export --to lerobot: the dataset stores no env spec; pass fps")
        fps = _fps(env_id)
    if not isinstance(fps, int) or isinstance(fps, bool) or fps < 1:
        raise ValueError(f"export --to lerobot: fps is {fps!r}; allowed: an integer >= 1")
    obs_keys = observation_keys(dataset.observation_space)
    features = {name: feature(sub, name) for name, (_, sub) in obs_keys.items()}
    features["action"] = feature(dataset.action_space, "the action")
    features["next.reward"] = {"dtype": "float32", "shape": [1], "names": None}
    features["next.done"] = {"dtype": "bool", "shape": [1], "names": None}
    for name in ("timestamp",):
        features[name] = {"dtype": "float32", "shape": [1], "names": None}
    for name in ("frame_index", "episode_index", "index", "task_index"):
        features[name] = {"dtype": "int64", "shape": [1], "names": None}
    video_keys = [k for k, f in features.items() if f["dtype"] == "video"]

    stage = out.parent / f".{out.name}.{uuid.uuid4().hex}.tmp"
    stage.mkdir(parents=True)
    try:
        columns: dict[str, list[np.ndarray]] = {k: [] for k in features}
        image_stats = {k: ImageStats() for k in video_keys}
        episodes: dict[str, list[Any]] = {}
        row = 0
        for e, episode in enumerate(_episodes(dataset)):
            n = len(episode.actions)
            if n == 0:
                continue
            for name, (key, _) in obs_keys.items():
                obs = episode.observations if key is None else episode.observations[key]
                obs = np.asarray(obs)[:n]
                if name in video_keys:
                    chunk, file = divmod(e, CHUNK_SIZE)
                    path = VIDEO_PATH.format(video_key=name, chunk_index=chunk, file_index=file)
                    _write_video(stage / path, obs, fps)
                    image_stats[name].add(obs)
                else:
                    columns[name].append(obs)
            columns["action"].append(np.asarray(episode.actions))
            columns["next.reward"].append(np.asarray(episode.rewards, np.float32))
            done = np.zeros(n, bool)
            done[-1] = bool(episode.terminations[-1] or episode.truncations[-1])
            columns["next.done"].append(done)
            columns["timestamp"].append((np.arange(n) / fps).astype(np.float32))
            columns["frame_index"].append(np.arange(n))
            columns["episode_index"].append(np.full(n, e))
            columns["index"].append(np.arange(row, row + n))
            columns["task_index"].append(np.zeros(n, np.int64))
            entry: dict[str, Any] = {
                "episode_index": e,
                "tasks": [env_id or "imitate the supervisor"],
                "length": n,
                "data/chunk_index": 0,
                "data/file_index": 0,
                "dataset_from_index": row,
                "dataset_to_index": row + n,
                "meta/episodes/chunk_index": 0,
                "meta/episodes/file_index": 0,
            }
            for name in video_keys:
                chunk, file = divmod(e, CHUNK_SIZE)
                entry[f"videos/{name}/chunk_index"] = chunk
                entry[f"videos/{name}/file_index"] = file
                entry[f"videos/{name}/from_timestamp"] = 0.0
                entry[f"videos/{name}/to_timestamp"] = n / fps
            for key, value in entry.items():
                episodes.setdefault(key, []).append(value)
            row += n
        if row == 0:
            raise ValueError("export --to lerobot: the dataset has no step to export")
        merged = {k: np.concatenate(v) for k, v in columns.items() if k not in video_keys}
        table = pa.table({k: _column(v, features[k]) for k, v in merged.items()})
        stats = {k: array_stats(np.asarray(v, features[k]["dtype"])) for k, v in merged.items()}
        stats.update({k: s.result() for k, s in image_stats.items()})
        (stage / "meta").mkdir()
        (stage / STATS_PATH).write_text(json.dumps(stats) + "\n")
        path = stage / DATA_PATH.format(chunk_index=0, file_index=0)
        path.parent.mkdir(parents=True)
        pq.write_table(table, path)
        path = stage / EPISODES_PATH
        path.parent.mkdir(parents=True)
        pq.write_table(pa.table(episodes), path)
        tasks = pa.table(
            {"task_index": [0], "__index_level_0__": [env_id or "imitate the supervisor"]}
        )
        pandas_meta = {
            b"pandas": json.dumps(
                {
                    "index_columns": ["__index_level_0__"],
                    "column_indexes": [],
                    "columns": [
                        {
                            "name": "task_index",
                            "field_name": "task_index",
                            "pandas_type": "int64",
                            "numpy_type": "int64",
                            "metadata": None,
                        },
                        {
                            "name": None,
                            "field_name": "__index_level_0__",
                            "pandas_type": "unicode",
                            "numpy_type": "object",
                            "metadata": None,
                        },
                    ],
                    "pandas_version": "2.0.0",
                }
            ).encode()
        }
        pq.write_table(tasks.replace_schema_metadata(pandas_meta), stage / "meta/tasks.parquet")
        for name in video_keys:
            h, w, c = features[name]["shape"]
            features[name]["info"] = {
                "video.height": h,
                "video.width": w,
                **VIDEO_INFO,
                "video.fps": fps,
                "video.channels": c,
                "has_audio": False,
            }
        n_episodes = len(episodes["episode_index"])
        info = {
            "codebase_version": CODEBASE_VERSION,
            "robot_type": None,
            "total_episodes": n_episodes,
            "total_frames": row,
            "total_tasks": 1,
            "chunks_size": CHUNK_SIZE,
            "data_files_size_in_mb": 100,
            "video_files_size_in_mb": 200,
            "fps": fps,
            "splits": {"train": f"0:{n_episodes}"},
            "data_path": DATA_PATH,
            "video_path": VIDEO_PATH if video_keys else None,
            "features": features,
        }
        (stage / "meta/info.json").write_text(json.dumps(info, indent=2) + "\n")
        if out.exists():
            shutil.rmtree(out)
        stage.rename(out)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    return info
