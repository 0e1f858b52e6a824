"""The optional extras that some tests need, and the markers that declare them.

A test that needs the `train` extra (torch and stable-baselines3) is marked
`@pytest.mark.train_extra`; one that needs Debian's chromium is marked `@pytest.mark.browser`
(`tests/conftest.py` registers both). Without the piece the test is skipped with the reason
`REASON` / `BROWSER_REASON`, so the README's test command passes on a fresh install; where CI has
installed it and set `FLUIDS_BENCH_TRAIN_TESTS=1` / `FLUIDS_BENCH_BROWSER_TESTS=1`, a missing
piece fails the test instead, so these tests can never be skipped silently there. `.ci/run`'s
second phase selects exactly these tests with `-m "train_extra or browser or client_extra"`.

`require_sb3()` and `require_torch()` return their module inside a marked test; called from an
unmarked one they fail, since CI's second phase would never run that test.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import shutil

import pytest

REASON = "needs the train extra (torch, stable-baselines3)"
INSTALL = 'pip install torch==2.13.0 stable-baselines3  (or pip install "fluids-bench[train]")'
TRAIN_ENV = "FLUIDS_BENCH_TRAIN_TESTS"
TRAIN_MODULES = ("torch", "stable_baselines3")

BROWSER_REASON = "needs Debian's chromium (apt-get install -y chromium)"
BROWSER_ENV = "FLUIDS_BENCH_BROWSER_TESTS"

# set by tests/conftest.py before each test: whether the running test carries the marker
current_test_is_marked = False


def missing_train_modules() -> list[str]:
    """The `train` extra's modules that are not installed (found without importing them)."""
    return [name for name in TRAIN_MODULES if importlib.util.find_spec(name) is None]


def chromium() -> str | None:
    """The path of the system's chromium, or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


def skip_or_fail(reason: str, env_var: str, install: str) -> None:
    """Skip with `reason`, or fail where `env_var=1` says CI installed the piece."""
    if os.environ.get(env_var) == "1":
        pytest.fail(f"{env_var}=1 but this test {reason}, and it is missing: {install}")
    pytest.skip(reason)


def require_train_extra() -> None:
    """Skip (or, under `FLUIDS_BENCH_TRAIN_TESTS=1`, fail) where torch or SB3 is missing."""
    if missing_train_modules():
        skip_or_fail(REASON, TRAIN_ENV, INSTALL)


def require_browser() -> None:
    """Skip (or, under `FLUIDS_BENCH_BROWSER_TESTS=1`, fail) where chromium is missing."""
    if chromium() is None:
        skip_or_fail(BROWSER_REASON, BROWSER_ENV, "apt-get install -y chromium")


def _marked() -> None:
    if not current_test_is_marked:
        pytest.fail(
            "this test needs the train extra: mark it @pytest.mark.train_extra so that it "
            "skips without the extra and .ci/run's second phase runs it"
        )


def require_sb3():
    """The `stable_baselines3` module, inside a test marked `train_extra`."""
    _marked()
    require_train_extra()
    return importlib.import_module("stable_baselines3")


TORCH_REASON = "needs the torch extra"
TORCH_INSTALL = 'pip install torch==2.13.0  (the CPU wheel; or pip install "fluids-bench[torch]")'


def require_torch():
    """The `torch` module, inside a test marked `train_extra`: a skip "needs the torch extra"
    where it is missing, except under `FLUIDS_BENCH_TRAIN_TESTS=1` (CI), where it fails."""
    _marked()
    if importlib.util.find_spec("torch") is None:
        skip_or_fail(TORCH_REASON, TRAIN_ENV, TORCH_INSTALL)
    return importlib.import_module("torch")
