"""Optional client libraries (TorchRL, ...) for the tests that use them.

``require_client(module, install)`` returns the imported module. Where it is not installed the
test is skipped with the install command, except where ``FLUIDS_BENCH_CLIENT_TESTS=1`` is set (CI
sets it after installing the clients): there a missing client fails the test, so the client
tests can never be skipped silently in CI.
"""

from __future__ import annotations

import importlib
import os

import pytest


def require_client(module: str, install: str):
    try:
        return importlib.import_module(module)
    except ImportError:
        if os.environ.get("FLUIDS_BENCH_CLIENT_TESTS") == "1":
            pytest.fail(f"FLUIDS_BENCH_CLIENT_TESTS=1 but {module} is missing: {install}")
        pytest.skip(f"needs the optional client {module}: {install}")
