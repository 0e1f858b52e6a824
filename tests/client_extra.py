"""Optional client libraries (TorchRL, ...) for the tests that use them.

``require_client(module, install)`` returns the imported module. Where it is not installed the
test is skipped with the install command, except where ``FLUIDS_BENCH_CLIENT_TESTS=1`` is set (CI
sets it after installing the clients): there a missing client fails the test, so the client
tests can never be skipped silently in CI.
"""

from __future__ import annotations

import importlib
import importlib.util

from train_extra import skip_or_fail

CLIENT_ENV = "FLUIDS_BENCH_CLIENT_TESTS"


def require_client(module: str, install: str):
    if importlib.util.find_spec(module) is None:
        skip_or_fail(f"needs the optional client {module}", CLIENT_ENV, install)
    return importlib.import_module(module)
