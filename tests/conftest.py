"""Shared by every test folder: pytest puts this folder on ``sys.path`` when it loads this file,
so test modules anywhere under ``tests/`` can ``from exact_compare import exactly_equal``."""

import os

import train_extra

# Gymnasium's check_env opens every declared render mode, FLUIDS' "human" (a pygame window)
# included. On a machine with no screen SDL then probes Mesa's EGL, and pygame.quit()
# terminates the EGL display that MuJoCo's off-screen renderers share in the same process: the
# next MuJoCo frame failed with EGL_NOT_INITIALIZED. SDL's dummy driver touches no display.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

# pytest-xdist's workers are the parallelism: a BLAS pool in each would oversubscribe the cores.
if os.environ.get("PYTEST_XDIST_WORKER"):
    from fluids_bench.core.pool import one_blas_thread

    one_blas_thread()


def pytest_configure(config):
    config.addinivalue_line(
        "markers",
        f"train_extra: {train_extra.REASON}; skipped without it unless "
        f"{train_extra.TRAIN_ENV}=1 (then it fails); .ci/run's second phase runs these",
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
    if item.get_closest_marker("browser") is not None:
        train_extra.require_browser()
