"""Shared by every test folder: pytest puts this folder on ``sys.path`` when it loads this file,
so test modules anywhere under ``tests/`` can ``from exact_compare import exactly_equal``."""

import os

# Gymnasium's check_env opens every declared render mode, FLUIDS' "human" (a pygame window)
# included. On a machine with no screen SDL then probes Mesa's EGL, and pygame.quit()
# terminates the EGL display that MuJoCo's off-screen renderers share in the same process: the
# next MuJoCo frame failed with EGL_NOT_INITIALIZED. SDL's dummy driver touches no display.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

# pytest-xdist's workers are the parallelism: a BLAS pool in each would oversubscribe the cores.
if os.environ.get("PYTEST_XDIST_WORKER"):
    from fluids_bench.core.parallel import one_blas_thread

    one_blas_thread()
