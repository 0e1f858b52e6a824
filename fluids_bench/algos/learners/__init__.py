"""Learners: the protocol every algorithm trains through, and its implementations.

- `protocol`: [`Learner`][fluids_bench.algos.learners.protocol.Learner] (`fit`/`predict`), the
  policy adapter and the `module:factory` resolution of `fluids-bench train --policy`;
- `sklearn`: the scikit-learn families (`PolicySpec`, `SklearnLearner`);
- `torch_nets`: `MLPLearner` (vector observations) and `CNNLearner` (images), needing the
  `torch` extra (imported only when used); `load_learner(path)` reloads their checkpoints.
"""

from __future__ import annotations

from typing import Any

from fluids_bench.algos.learners.protocol import (
    Learner,
    LearnerPolicy,
    check_learner,
    make_learner,
    resolve_factory,
)
from fluids_bench.algos.learners.sklearn import PolicySpec, SklearnLearner

TORCH_NAMES = ("MLPLearner", "CNNLearner", "TorchLearner", "load_learner")

__all__ = [
    "Learner",
    "LearnerPolicy",
    "PolicySpec",
    "SklearnLearner",
    "check_learner",
    "make_learner",
    "resolve_factory",
    *TORCH_NAMES,
]


def __getattr__(name: str) -> Any:
    # the torch learners import torch: only when asked for
    if name in TORCH_NAMES:
        from fluids_bench.algos.learners import torch_nets

        return getattr(torch_nets, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
