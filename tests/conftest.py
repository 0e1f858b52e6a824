"""Shared by every test folder: pytest puts this folder on ``sys.path`` when it loads this file,
so test modules anywhere under ``tests/`` can ``from exact_compare import exactly_equal``."""

import os

import pytest
import train_extra

# the fuzz tests' full sets (tests/test_fuzz.py): a sample runs always, the rest on request
FULL_FUZZ_ENV = "FLUIDS_BENCH_FULL_FUZZ"
FULL_FUZZ_REASON = f"the full fuzz set: {FULL_FUZZ_ENV}=1 runs it (a sample runs always)"

# Gymnasium's check_env opens every declared render mode, FLUIDS' "human" (a pygame window)
# included. On a machine with no screen SDL then probes Mesa's EGL, and pygame.quit()
# terminates the EGL display that MuJoCo's off-screen renderers share in the same process: the
# next MuJoCo frame failed with EGL_NOT_INITIALIZED. SDL's dummy driver touches no display.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

# pytest-xdist's workers are the parallelism: a BLAS pool in each would oversubscribe the cores.
if os.environ.get("PYTEST_XDIST_WORKER"):
    from fluids_bench.core.parallel import one_blas_thread

    one_blas_thread()


def pytest_configure(config):
    config.addinivalue_line(
        "markers",
        f"train_extra: {train_extra.REASON}; skipped without it unless "
        f"{train_extra.TRAIN_ENV}=1 (then it fails); .ci/run's second phase runs these",
    )
    config.addinivalue_line(
        "markers",
        f"fuzz_full: {FULL_FUZZ_REASON}",
    )
    config.addinivalue_line(
        "markers",
        "client_extra: needs an optional client library (TorchRL, ...; tests/client_extra.py); "
        "skipped without it unless FLUIDS_BENCH_CLIENT_TESTS=1 (then it fails); .ci/run's "
        "second phase runs these",
    )
    config.addinivalue_line(
        "markers",
        f"browser: {train_extra.BROWSER_REASON}; skipped without it unless "
        f"{train_extra.BROWSER_ENV}=1 (then it fails); .ci/run's second phase runs these",
    )


def pytest_runtest_setup(item):
    marked = item.get_closest_marker("train_extra") is not None
    train_extra.current_test_is_marked = marked
    if marked:
        train_extra.require_train_extra()
    if item.get_closest_marker("fuzz_full") is not None and os.environ.get(FULL_FUZZ_ENV) != "1":
        pytest.skip(FULL_FUZZ_REASON)
    if item.get_closest_marker("browser") is not None:
        train_extra.require_browser()
