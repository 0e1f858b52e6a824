"""Subcommands of the ``fluids-bench`` command line (see :mod:`fluids_bench.cli`)."""
