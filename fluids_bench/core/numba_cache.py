"""Where numba keeps the compiled kernels: a user cache directory, never the installed package.

With ``cache=True`` numba writes its cache next to the source when that folder is writable, i.e.
into ``site-packages/fluids_bench/**/__pycache__`` for a normal install. pip does not know those
files, so uninstalling or reinstalling (``pip install -e .`` after ``pip install .``) leaves the
folders behind as an empty namespace package that hides the real one. numba reads
``NUMBA_CACHE_DIR`` instead when it is set; the package sets it, unless the user already has,
before any kernel module is imported (``fluids_bench/__init__.py`` calls this first).
"""

from __future__ import annotations

import os
import sys
from collections.abc import MutableMapping


def default_cache_dir(environ: MutableMapping[str, str]) -> str:
    """``$XDG_CACHE_HOME/fluids-bench/numba``, with ``~/.cache`` when XDG_CACHE_HOME is unset
    or not absolute (the XDG rule)."""
    base = environ.get("XDG_CACHE_HOME", "")
    if not os.path.isabs(base):
        base = os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "fluids-bench", "numba")


def use_user_cache_dir(environ: MutableMapping[str, str] = os.environ) -> str:
    """Point numba's kernel cache at :func:`default_cache_dir` unless ``NUMBA_CACHE_DIR`` is
    already set (non-empty); return the directory in use. Child processes inherit it."""
    if not environ.get("NUMBA_CACHE_DIR"):
        environ["NUMBA_CACHE_DIR"] = default_cache_dir(environ)
        if environ is os.environ and "numba" in sys.modules:
            # numba was imported before us and read its settings then; its compiler re-reads
            # them on every compile, but a kernel's cache locator is chosen at decoration time
            from numba.core import config

            config.reload_config()
    return environ["NUMBA_CACHE_DIR"]
