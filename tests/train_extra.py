"""The optional ``train`` extra (stable-baselines3 on CPU torch) for the tests that need it.

``require_sb3()`` returns the ``stable_baselines3`` module. Where it is not installed the test is
skipped with the install command, except where ``FLUIDS_BENCH_TRAIN_TESTS=1`` is set (CI sets
it after installing the extra): there a missing stable-baselines3 fails the test, so the
recipe and checker tests can never be skipped silently in CI.
"""

from __future__ import annotations

import importlib
import os

import pytest

INSTALL = 'pip install torch==2.13.0 stable-baselines3  (or pip install "fluids-bench[train]")'


def require_sb3():
    try:
        return importlib.import_module("stable_baselines3")
    except ImportError:
        if os.environ.get("FLUIDS_BENCH_TRAIN_TESTS") == "1":
            pytest.fail(f"FLUIDS_BENCH_TRAIN_TESTS=1 but stable-baselines3 is missing: {INSTALL}")
        pytest.skip(f"needs the optional `train` extra: {INSTALL}")


TORCH_INSTALL = 'pip install torch==2.13.0  (the CPU wheel; or pip install "fluids-bench[torch]")'


def require_torch():
    """The `torch` module; a skip "needs the torch extra" where it is missing, except under
    FLUIDS_BENCH_TRAIN_TESTS=1 (CI), where a missing torch fails the test."""
    try:
        return importlib.import_module("torch")
    except ImportError:
        if os.environ.get("FLUIDS_BENCH_TRAIN_TESTS") == "1":
            pytest.fail(f"FLUIDS_BENCH_TRAIN_TESTS=1 but torch is missing: {TORCH_INSTALL}")
        pytest.skip(f"needs the torch extra: {TORCH_INSTALL}")
