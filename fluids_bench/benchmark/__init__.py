"""The benchmark: one id per task, seed splits, OOD sets, metrics, `evaluate` and scorecards.

- [`SUITE`][fluids_bench.benchmark.suite.SUITE] and its tasks (`suite.py`);
- the seed splits and the training guard (`fluids_bench.core.splits`, on the ground floor
  because collect and the algorithm harness call the guard);
- the metrics (`metrics.py`: normalised score, IQM with stratified-bootstrap intervals through
  rliable, the label-efficiency curve);
- [`evaluate`][fluids_bench.benchmark.evaluator.evaluate] (`evaluator.py`), its scorecards
  (`scorecard.py`) and plots (`plots.py`).

Names are imported lazily.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "SUITE": "suite",
    "Suite": "suite",
    "Task": "suite",
    "OODSet": "suite",
    "FLUIDS_ID": "suite",
    "TASK_NAMES": "suite",
    "evaluate": "evaluator",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'fluids_bench.benchmark' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"fluids_bench.benchmark.{_EXPORTS[name]}"), name)
    globals()[name] = value
    return value
