"""FLUIDS batched: B worlds behind one Gymnasium ``VectorEnv`` (see :class:`FluidsVectorEnv`),
in one process or over several (:class:`FluidsWorkerVectorEnv`)."""

from fluids_bench.tasks.fluids.vector.env import FluidsVectorEnv
from fluids_bench.tasks.fluids.vector.workers import FluidsWorkerVectorEnv

__all__ = ["FluidsVectorEnv", "FluidsWorkerVectorEnv"]
