"""Algorithmic supervisors: one per task, all honouring :mod:`fluids_bench.supervisors.base`."""
