"""Finished episodes of a collection on disk as they come, so that an interrupted `collect` keeps
them and `collect --resume` finishes the dataset.

A collection into dataset id `NAME` keeps, under the datasets root, the hidden folder
`.fluids-bench-partial/<NAME, quoted>/` (Minari skips dot-folders when listing) with:

- `run.json`: the arguments the data depend on (env id and kwargs, actor, seed, episodes,
  step limit, data format); `--resume` refuses other ones, naming them;
- `episode_<i>.npz`: episode `i` exactly as it will be exported (Minari's episode buffer:
  observations, labels, rewards, terminations, truncations, executed actions, provenance),
  written atomically (a temporary file renamed into place) and read back with
  `allow_pickle=False`: a folder a user is given can never run code.

The folder is removed once the complete dataset is exported. The dataset of an interrupted run
is exported from the same files, so a resumed collection and an uninterrupted one are
identical.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
from pathlib import Path
from typing import Any
from urllib.parse import quote

import numpy as np
from minari.data_collector import EpisodeBuffer

PARTIAL_DIR = ".fluids-bench-partial"
RUN_FILE = "run.json"
_SEP = "/"  # joins the keys of nested dicts in an episode file


def _flatten(prefix: str, value: Any, out: dict[str, np.ndarray]) -> None:
    if isinstance(value, dict):
        for key, sub in value.items():
            if _SEP in key:
                raise ValueError(f"an observation key contains {_SEP!r}: {key!r}")
            _flatten(f"{prefix}{_SEP}{key}", sub, out)
    else:
        out[prefix] = np.asarray(value)


def _unflatten(prefix: str, arrays: dict[str, np.ndarray]) -> Any:
    if prefix in arrays:
        return arrays[prefix]
    tree: dict[str, Any] = {}
    for name, array in arrays.items():
        if name.startswith(prefix + _SEP):
            *path, leaf = name[len(prefix) + 1 :].split(_SEP)
            node = tree
            for key in path:
                node = node.setdefault(key, {})
            node[leaf] = array
    return tree


def buffer_arrays(buffer: EpisodeBuffer) -> dict[str, np.ndarray]:
    """The arrays of one episode buffer (no objects: they load without pickle)."""
    out: dict[str, np.ndarray] = {"seed": np.asarray(-1 if buffer.seed is None else buffer.seed)}
    _flatten("observations", buffer.observations, out)
    _flatten("actions", buffer.actions, out)
    for name in ("rewards", "terminations", "truncations"):
        out[name] = np.asarray(getattr(buffer, name))
    for key, value in (buffer.infos or {}).items():
        out[f"infos{_SEP}{key}"] = np.asarray(value)
        if isinstance(value, list):
            out[f"list{_SEP}{key}"] = np.asarray(True)
    return out


def buffer_from_arrays(index: int, arrays: dict[str, np.ndarray]) -> EpisodeBuffer:
    """The episode buffer `buffer_arrays` came from, with id `index`."""
    infos: dict[str, Any] = {}
    for name, array in arrays.items():
        if name.startswith(f"infos{_SEP}"):
            key = name[len("infos") + 1 :]
            infos[key] = array.tolist() if f"list{_SEP}{key}" in arrays else array
    seed = int(arrays["seed"])
    return EpisodeBuffer(
        id=index,
        seed=None if seed < 0 else seed,
        observations=_unflatten("observations", arrays),
        actions=_unflatten("actions", arrays),
        rewards=arrays["rewards"],
        terminations=arrays["terminations"],
        truncations=arrays["truncations"],
        infos=infos,
    )


def _write_atomic(path: Path, write: Any) -> None:
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(temporary, "wb") as handle:
            write(handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temporary, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            temporary.unlink()


class PartialCollection:
    """The finished episodes of one collection into `dataset_id` under the datasets `root`."""

    def __init__(self, root: Path, dataset_id: str) -> None:
        self.dataset_id = dataset_id
        self.folder = Path(root) / PARTIAL_DIR / quote(dataset_id, safe="")

    def exists(self) -> bool:
        """Whether an earlier collection into this id stopped before its export."""
        return (self.folder / RUN_FILE).is_file()

    def start(self, run: dict[str, Any]) -> None:
        """Begin afresh with the arguments `run` (what an earlier run left is removed)."""
        self.remove()
        self.folder.mkdir(parents=True)
        text = json.dumps(run, sort_keys=True, indent=1).encode()
        _write_atomic(self.folder / RUN_FILE, lambda handle: handle.write(text))

    def run(self) -> dict[str, Any]:
        """The arguments the collection was started with."""
        return json.loads((self.folder / RUN_FILE).read_text())

    def check_same(self, run: dict[str, Any]) -> None:
        """ValueError naming every argument of `run` that differs from the stored run's."""
        stored = self.run()
        differ = [
            f"{key} is {run.get(key)!r}, the interrupted run's {stored.get(key)!r}"
            for key in sorted(set(stored) | set(run))
            if stored.get(key) != run.get(key)
        ]
        if differ:
            raise ValueError(
                f"--resume of {self.dataset_id!r}: " + "; ".join(differ) + "; allowed: the "
                "interrupted run's arguments (or --overwrite to start again)"
            )

    def done(self) -> list[int]:
        """Indices of the episodes on disk, in order."""
        if not self.folder.is_dir():
            return []
        names = (p.name for p in self.folder.glob("episode_*.npz"))
        return sorted(int(name[len("episode_") : -len(".npz")]) for name in names)

    def save(self, index: int, buffer: EpisodeBuffer) -> None:
        """Write episode `index` (atomically)."""
        arrays = buffer_arrays(buffer)
        _write_atomic(self._path(index), lambda handle: np.savez(handle, **arrays))

    def load(self, index: int) -> EpisodeBuffer:
        """Episode `index` as it was saved (never unpickled)."""
        with np.load(self._path(index), allow_pickle=False) as data:
            return buffer_from_arrays(index, {name: data[name] for name in data.files})

    def remove(self) -> None:
        """Remove the folder (and the parent folder when no other collection uses it)."""
        shutil.rmtree(self.folder, ignore_errors=True)
        with contextlib.suppress(OSError):
            self.folder.parent.rmdir()

    def _path(self, index: int) -> Path:
        return self.folder / f"episode_{index:07d}.npz"
