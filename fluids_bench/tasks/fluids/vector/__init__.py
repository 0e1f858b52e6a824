"""FLUIDS batched: B worlds behind one Gymnasium ``VectorEnv`` (see :class:`FluidsVectorEnv`)."""

from fluids_bench.tasks.fluids.vector.env import FluidsVectorEnv

__all__ = ["FluidsVectorEnv"]
