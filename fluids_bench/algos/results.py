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
    """The state of a run after one iteration; every count and time is cumulative.

    Data counters:

    - `demonstrations`: rollouts collected so far (the source's trajectory-level x-axis);
    - `training_labels`: state–label pairs in the training set (the source's state-level
      x-axis: labelled examples used for training);
    - `estimation_labels`: labelled pairs kept out of training to estimate DART's noise;
    - `labels_requested`: every supervisor label the algorithm used, the sum of the two above
      (labels of states it chose not to query, or discarded by subsampling, do not count).

    Compute (seconds; evaluation is never counted):

    - `train_seconds`: fitting the learner (and SHIV's risk model, DART's noise estimate)
      to produce the policy evaluated here: every fit so far plus, when the algorithm had not
      just fitted on all its data, the fit of the evaluated policy;
    - `wall_seconds`: everything the algorithm did so far (collection, the supervisor's
      labelling, fitting), the source's "total computation time", plus that same extra fit.

    `collection_return` is the mean return of the policy that acted while collecting this
    iteration's data (the bottom rows of the source's Fig. 3.3). At an evaluation,
    `eval_return` is the learner's mean return over the evaluation episodes and
    `eval_return_se` its standard error; `eval_success_rate` (with its standard error) and
    `eval_collisions` (mean collision events per episode) are filled for envs that report
    `info["is_success"]` and `info["collisions"]` (e.g. FLUIDS), else None.
    """

    iteration: int
    demonstrations: int
    labels_requested: int
    train_seconds: float
    collection_return: float
    eval_return: float | None = None
    normalised_performance: float | None = None
    extras: dict[str, float] = field(default_factory=dict)
    training_labels: int = 0
    estimation_labels: int = 0
    wall_seconds: float = 0.0
    eval_return_se: float | None = None
    eval_success_rate: float | None = None
    eval_success_se: float | None = None
    eval_collisions: float | None = None


@dataclass
class RunResult:
    """A whole run: its config, the supervisor's reference return and one record per iteration.

    `policy` (the learner fit on all training pairs) and `dataset` stay out of the JSON.
    """

    algo: str
    config: dict[str, Any]
    supervisor_return: float
    records: list[IterationRecord]
    # the supervisor on the evaluation seeds: return_se, success_rate, collisions (or None)
    supervisor_metrics: dict[str, float | None] = field(default_factory=dict)
    policy: Policy | None = field(default=None, repr=False, compare=False)
    dataset: Dataset | None = field(default=None, repr=False, compare=False)  # training pairs

    def to_dict(self, include_timing: bool = True) -> dict[str, Any]:
        """JSON-friendly form; without timing it is identical for identical seeds."""
        records = [asdict(r) for r in self.records]
        if not include_timing:
            for r in records:
                r.pop("train_seconds")
                r.pop("wall_seconds")
        return {
            "algo": self.algo,
            "config": self.config,
            "supervisor_return": self.supervisor_return,
            "supervisor_metrics": dict(self.supervisor_metrics),
            "records": records,
        }

    @property
    def final(self) -> IterationRecord:
        return self.records[-1]

    def evaluated(self) -> list[IterationRecord]:
        """The records that carry an evaluation."""
        return [r for r in self.records if r.eval_return is not None]


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes) -> None:
    """Write `data` to a temporary file next to `path`, then rename it into place.

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
    """Atomically write `payload` as indented JSON (NaN/inf refused: not valid JSON)."""
    text = json.dumps(payload, indent=2, allow_nan=False) + "\n"
    write_bytes_atomic(path, text.encode("utf-8"))
