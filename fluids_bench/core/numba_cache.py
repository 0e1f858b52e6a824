"""Where numba keeps the compiled kernels: a user cache directory, never the installed package.

With `cache=True` numba writes its cache next to the source when that folder is writable, i.e.
into `site-packages/fluids_bench/**/__pycache__` for a normal install. pip does not know those
files, so uninstalling or reinstalling (`pip install -e .` after `pip install .`) leaves the
folders behind as an empty namespace package that hides the real one. numba reads
`NUMBA_CACHE_DIR` instead when it is set; the package sets it, unless the user already has,
before any kernel module is imported (`fluids_bench/__init__.py` calls this first).

numba checks a cached kernel only against its own file's timestamp: a kernel that calls (and
inlines) kernels of another file keeps its old machine code when only that file changes. The
directory therefore ends in a digest of the package's kernel sources (every module that
compiles with `njit`), so an edited kernel anywhere recompiles its callers too. Module-level
constants a kernel reads from a module without kernels are not covered: pass them as arguments
(as the kernels here do) or keep them in the kernel's module.
"""

from __future__ import annotations

import functools
import hashlib
import os
import sys
from collections.abc import MutableMapping
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1]


@functools.lru_cache(maxsize=4)
def kernel_digest(root: Path = PACKAGE) -> str:
    """A digest (16 hex digits) of every module under `root` that compiles with `njit`:
    its path and its text (a few milliseconds at import)."""
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        text = path.read_bytes()
        if b"njit" in text:
            digest.update(path.relative_to(root).as_posix().encode() + b"\0" + text)
    return digest.hexdigest()[:16]


def default_cache_dir(environ: MutableMapping[str, str]) -> str:
    """`$XDG_CACHE_HOME/fluids-bench/numba/<kernel digest>`, with `~/.cache` when
    XDG_CACHE_HOME is unset or not absolute (the XDG rule)."""
    base = environ.get("XDG_CACHE_HOME", "")
    if not os.path.isabs(base):
        base = os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "fluids-bench", "numba", kernel_digest())


def use_user_cache_dir(environ: MutableMapping[str, str] = os.environ) -> str:
    """Point numba's kernel cache at `default_cache_dir` unless `NUMBA_CACHE_DIR` is
    already set (non-empty); return the directory in use. Child processes inherit it."""
    if not environ.get("NUMBA_CACHE_DIR"):
        environ["NUMBA_CACHE_DIR"] = default_cache_dir(environ)
        if environ is os.environ and "numba" in sys.modules:
            # numba was imported before us and read its settings then; its compiler re-reads
            # them on every compile, but a kernel's cache locator is chosen at decoration time
            from numba.core import config

            config.reload_config()
    return environ["NUMBA_CACHE_DIR"]
