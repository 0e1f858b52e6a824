"""`core.compiled`: a callee (no Python wrapper) is called by kernels and, through its twin,
from Python, with the same results; the twin's cache entries are its own."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import fluids_bench

MODULE = """
from fluids_bench.core.compiled import callee, kernel

@callee
def inner(a, b):
    return a.sum() + b

@kernel
def outer(a):
    return inner(a, 1.0) * 2.0
"""

SCRIPT = """
import numpy as np
import fluids_bench
import mod_under_test as m
a = np.arange(4.0)
print(m.outer(a), m.inner(a, 2.0), type(m.inner).__name__)
"""


def test_a_callee_runs_from_kernels_and_from_python_and_caches_apart(tmp_path):
    (tmp_path / "mod_under_test.py").write_text(MODULE)
    cache = tmp_path / "cache"
    package = str(Path(fluids_bench.__file__).parents[1])
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env |= {"NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": os.pathsep.join([str(tmp_path), package])}
    for _ in range(2):  # compiled, then loaded from the cache
        out = subprocess.run(
            [sys.executable, "-c", SCRIPT], env=env, cwd=tmp_path, capture_output=True, text=True
        )
        assert out.returncode == 0, out.stderr
        assert out.stdout.split() == ["14.0", "8.0", "_Callee"]
    names = sorted(p.name.split("-")[0] for p in cache.rglob("*.nbi"))
    assert names == [
        "mod_under_test.inner",
        "mod_under_test.inner__called_from_python",
        "mod_under_test.outer",
    ]
