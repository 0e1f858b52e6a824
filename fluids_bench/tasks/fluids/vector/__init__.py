"""FLUIDS batched: B worlds behind one Gymnasium `VectorEnv` (see `FluidsVectorEnv`),
in one process or over several (`FluidsWorkerVectorEnv`)."""

from fluids_bench.tasks.fluids.vector.env import FluidsVectorEnv
from fluids_bench.tasks.fluids.vector.workers import FluidsWorkerVectorEnv

__all__ = ["FluidsVectorEnv", "FluidsWorkerVectorEnv"]
