"""A run's finished work on disk, so that an interrupted run continues where it stopped.

Every algorithm is deterministic given its config, so a run does not need its loop's state saved
to continue: it can run again from the start, taking each rollout, evaluation and record that
the interrupted run finished from its checkpoint folder instead of computing it again. Only the
fits are redone (in the driver, on the same data, with the same seeds: the same learners); the
rollouts, which are the expensive part, are not. The folder holds:

- `run.json`: the algorithm, its config (without the execution settings, see
  `EXECUTION_FIELDS`) and the suite's version; a folder of
  another run is refused, so that no rollout of another config is ever reused;
- `rollout-NNNNNN.pkl`: the n-th rollout the algorithm collected (its trajectory);
- `eval-NNNN.pkl`: the n-th evaluation's summary (0 is the supervisor's);
- `record-NNNN.pkl`: the record of iteration NNNN, as first computed (with its timing).

Every file is written atomically as soon as its work is done, so Ctrl-C or a crash keeps
everything finished before it, including the finished rollouts of an unfinished iteration.
A rerun checks each record it recomputes against the saved one and fails loudly if they
differ. The files are pickles: load only checkpoint folders you wrote yourself.
"""

from __future__ import annotations

import json
import os
import pickle
from pathlib import Path
from typing import Any

from fluids_bench.algos.results import write_bytes_atomic, write_json_atomic

KEY_FILE = "run.json"


def run_key(algo: str, config: Any) -> dict[str, Any]:
    """What a checkpoint folder belongs to, JSON-normalised (tuples become lists)."""
    from fluids_bench import __version__

    key = {"algo": algo, "config": config.to_dict(), "fluids_bench": __version__}
    return json.loads(json.dumps(key))


def _differences(saved: dict[str, Any], key: dict[str, Any]) -> list[str]:
    out = [k for k in ("algo", "fluids_bench") if saved.get(k) != key[k]]
    old, new = saved.get("config", {}), key["config"]
    out += [f"config.{k}" for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)]
    return out


class Checkpoint:
    """The checkpoint folder `folder` of one run of `algo` with `config`."""

    def __init__(self, folder: str | os.PathLike[str], algo: str, config: Any) -> None:
        self.folder = Path(folder)
        key = run_key(algo, config)
        key_path = self.folder / KEY_FILE
        if key_path.is_file():
            saved = json.loads(key_path.read_text())
            differences = _differences(saved, key)
            if differences:
                raise ValueError(
                    f"checkpoint folder {self.folder} holds a run with other settings "
                    f"({', '.join(differences)} differ); allowed: a folder of the same "
                    "algorithm, config and fluids-bench version, or a new folder"
                )
        elif self.folder.exists() and any(self.folder.iterdir()):
            raise ValueError(
                f"checkpoint folder {self.folder} is not empty and holds no {KEY_FILE}; "
                "allowed: a checkpoint folder of this run, or a new folder"
            )
        else:
            write_json_atomic(key_path, key)

    def _path(self, name: str) -> Path:
        return self.folder / f"{name}.pkl"

    def load(self, name: str) -> Any | None:
        """The object saved as `name`, or None."""
        path = self._path(name)
        if not path.is_file():
            return None
        return pickle.loads(path.read_bytes())

    def save(self, name: str, value: Any) -> None:
        write_bytes_atomic(self._path(name), pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL))

    def count(self, prefix: str) -> int:
        """How many `prefix-*` entries are saved (e.g. finished records)."""
        return len(list(self.folder.glob(f"{prefix}-*.pkl")))
