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
(as the kernels here do) or keep them in the kernel's module. The digest also covers the
versions of Python, numba, llvmlite and numpy.

numba files a kernel's cache under a hash of its source file's absolute folder, so the same code
at another path (site-packages after `pip install .`, the checkout after `pip install -e .`)
compiled everything again. This package's kernels are filed by their path inside the package
instead ([`install_package_locator`][fluids_bench.core.numba_cache.install_package_locator]):
with numba's own check of the source's content hash, a cache now depends on the code and the
versions only, and survives a reinstall. The first compile of a FLUIDS kernel in a process
prints one line to stderr (`COMPILE_MESSAGE`): a cold start takes a minute or more.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.abc
import importlib.metadata
import importlib.util
import os
import sys
from collections.abc import MutableMapping
from pathlib import Path
from typing import Any

PACKAGE = Path(__file__).resolve().parents[1]
VERSIONED = ("numba", "llvmlite", "numpy")  # distributions whose versions key the cache
# what a cold compile of the FLUIDS kernels takes on one core: 64-75 CPU-s measured with numba
# 0.68 (FLUIDS-v1 and v4, reset and 50 steps; the vector env 83: its batch kernels too;
# scripts/benchmarks/bench_compile.py, docs/results/bench_compile.json); more wall time on a
# loaded machine
COLD_COMPILE_S = 70
COMPILE_MESSAGE = "fluids-bench: compiling FLUIDS kernels, once, ~{seconds} s (cached in {where})"
_FLUIDS = "fluids_bench.tasks.fluids"


@functools.lru_cache(maxsize=4)
def kernel_digest(root: Path = PACKAGE) -> str:
    """A digest (16 hex digits) of every module under `root` that compiles with `njit`:
    its path inside `root` and its text, and the versions of Python and of `VERSIONED` (a few
    milliseconds at import)."""
    digest = hashlib.sha256(sys.version.encode())
    for name in VERSIONED:
        try:
            digest.update(f"{name}=={importlib.metadata.version(name)}".encode())
        except importlib.metadata.PackageNotFoundError:
            digest.update(f"{name} missing".encode())
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
    if environ is os.environ:
        install_package_locator()
    return environ["NUMBA_CACHE_DIR"]


def install_package_locator() -> None:
    """Make numba file this package's kernel caches by their path inside the package (see the
    module docstring), now if numba is loaded, else as soon as it is: a kernel's locator is
    chosen when its module decorates it."""
    caching = sys.modules.get("numba.core.caching")
    if caching is not None:
        _register(caching)
    elif not any(isinstance(finder, _AfterCaching) for finder in sys.meta_path):
        sys.meta_path.insert(0, _AfterCaching())


class _AfterCaching(importlib.abc.MetaPathFinder):
    """Registers the locator right after `numba.core.caching` is executed (then removes itself)."""

    def find_spec(self, fullname: str, path: Any, target: Any = None) -> Any:
        if fullname != "numba.core.caching":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(fullname)
        if spec is None or spec.loader is None:
            return spec
        execute = spec.loader.exec_module

        def exec_module(module: Any) -> None:
            execute(module)
            _register(module)

        spec.loader.exec_module = exec_module
        return spec


def _inside(path: str, root: Path) -> Path | None:
    """`path`'s folder relative to `root`, or None when it is not below it."""
    try:
        return Path(path).resolve().parent.relative_to(root)
    except (OSError, ValueError):
        return None


def _register(caching: Any) -> None:
    if any(getattr(c, "fluids_bench", False) for c in caching.CacheImpl._locator_classes):
        return

    class PackageCacheLocator(caching.UserProvidedCacheLocator):
        """A kernel of this package: `NUMBA_CACHE_DIR/fluids_bench/<its folder in the package>`
        (numba's own locator hashes the folder's absolute path)."""

        fluids_bench = True

        def __init__(self, py_func: Any, py_file: str) -> None:
            super().__init__(py_func, py_file)
            folder = _inside(py_file, PACKAGE) or Path()
            self._cache_path = os.path.join(caching.config.CACHE_DIR, "fluids_bench", *folder.parts)

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            if not caching.config.CACHE_DIR or _inside(py_file, PACKAGE) is None:
                return None
            _listen_for_compiles()
            return super().from_function(py_func, py_file)

    caching.CacheImpl._locator_classes.insert(0, PackageCacheLocator)


@functools.cache
def _listen_for_compiles() -> None:
    """Print `COMPILE_MESSAGE` when the first FLUIDS kernel of this process is compiled (numba
    signals a compile only on a cache miss) and no FLUIDS kernel is cached yet."""
    from numba.core import config, event

    class Listener(event.Listener):
        said = False

        def on_start(self, ev: Any) -> None:
            dispatcher = (ev.data or {}).get("dispatcher")
            module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
            if not self.said and module.startswith(_FLUIDS):
                self.said = True  # one look per process
                where = config.CACHE_DIR
                cached = Path(where, *_FLUIDS.split(".")).rglob("*.nbi") if where else ()
                if next(iter(cached), None) is None:  # a cold cache, not one new signature
                    line = COMPILE_MESSAGE.format(seconds=COLD_COMPILE_S, where=where)
                    print(line, file=sys.stderr, flush=True)

        def on_end(self, ev: Any) -> None:
            pass

    event.register("numba:compile", Listener())  # for the rest of the process
