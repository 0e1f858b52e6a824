"""What every run records, as JSON-friendly dataclasses, and atomic file writes."""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from fluids_bench.algos.dataset import Dataset
from fluids_bench.algos.policies import Policy


@dataclass
class IterationRecord:
    """The state of a run after one iteration.

    ``labels_requested`` counts the supervisor labels the algorithm has used so far (training
    and held-out pairs; labels of states it chose not to query, or discarded by subsampling,
    do not count). ``train_seconds`` is the compute spent fitting to produce the policy
    evaluated here: every fit the algorithm needed so far plus, when the algorithm had not
    just fitted on all its data, the fit of the evaluated policy. ``collection_return`` is the
    mean return of the policy that acted while collecting this iteration's data (the bottom
    rows of the source's Fig. 3.3).
    """

    iteration: int
    demonstrations: int
    labels_requested: int
    train_seconds: float
    collection_return: float
    eval_return: float | None = None
    normalised_performance: float | None = None
    extras: dict[str, float] = field(default_factory=dict)


@dataclass
class RunResult:
    """A whole run: its config, the supervisor's reference return and one record per iteration.

    ``policy`` (the learner fit on all training pairs) and ``dataset`` stay out of the JSON.
    """

    algo: str
    config: dict[str, Any]
    supervisor_return: float
    records: list[IterationRecord]
    policy: Policy | None = field(default=None, repr=False, compare=False)
    dataset: Dataset | None = field(default=None, repr=False, compare=False)  # training pairs

    def to_dict(self, include_timing: bool = True) -> dict[str, Any]:
        """JSON-friendly form; without timing it is identical for identical seeds."""
        records = [asdict(r) for r in self.records]
        if not include_timing:
            for r in records:
                r.pop("train_seconds")
        return {
            "algo": self.algo,
            "config": self.config,
            "supervisor_return": self.supervisor_return,
            "records": records,
        }

    @property
    def final(self) -> IterationRecord:
        return self.records[-1]

    def evaluated(self) -> list[IterationRecord]:
        """The records that carry an evaluation."""
        return [r for r in self.records if r.eval_return is not None]


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to a temporary file next to ``path``, then rename it into place.

    A reader never sees a half-written file, and an interrupted run leaves the old one intact.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp creates 0600; give the usual mode
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_json_atomic(path: str | os.PathLike[str], payload: Any) -> None:
    """Atomically write ``payload`` as indented JSON (NaN/inf refused: not valid JSON)."""
    text = json.dumps(payload, indent=2, allow_nan=False) + "\n"
    write_bytes_atomic(path, text.encode("utf-8"))
