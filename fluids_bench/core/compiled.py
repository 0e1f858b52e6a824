"""How FLUIDS' kernels are compiled: numba's `njit` with the options they share.

- [`kernel`][fluids_bench.core.compiled.kernel]: `njit(cache=True, nogil=True)` without the
  C-callable wrapper numba builds for every compiled function (for first-class function
  values, which no kernel uses): its lowering and machine code were some 5 % of a cold start.
- [`callee`][fluids_bench.core.compiled.callee]: a kernel that other kernels call. It is also
  compiled without the Python wrapper (unboxing each of its array arguments, boxing its
  results), which only a call from Python needs; each caller's machine code then carries one
  wrapper fewer per callee below it. A call from Python (a test's numpy reference, a slower
  per-step path) goes to a twin compiled with the wrappers on its first such call, cached under
  its own name: numba files cache entries by function name and signature, not by these
  options, so the twin must not share the callee's entries.

Neither changes the kernels' machine code: results stay bit-identical.
"""

from __future__ import annotations

import types
from collections.abc import Callable
from typing import Any

from numba import njit
from numba.core import config
from numba.core.registry import CPUDispatcher

OPTIONS = {"cache": True, "nogil": True, "no_cfunc_wrapper": True}
TWIN_SUFFIX = "__called_from_python"  # the twin's qualified name: the callee's plus this


def kernel(func: Callable | None = None, **options: Any) -> Any:
    """`njit` with `OPTIONS` (and `options`, e.g. `inline="always"`); as `@kernel` or
    `@kernel(...)`."""
    decorate = njit(**OPTIONS, **options)
    return decorate if func is None else decorate(func)


class _Callee(CPUDispatcher):
    """A dispatcher compiled without its Python wrapper; Python calls go to `python_twin`."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self.python_twin()(*args, **kwargs)

    def python_twin(self) -> Any:
        """The same function compiled as a `kernel` (with the Python wrapper), made once."""
        twin = self.__dict__.get("_python_twin")
        if twin is None:
            f = self.py_func
            copy = types.FunctionType(
                f.__code__, f.__globals__, f.__name__, f.__defaults__, f.__closure__
            )
            copy.__qualname__ = f.__qualname__ + TWIN_SUFFIX
            copy.__module__, copy.__doc__ = f.__module__, f.__doc__
            twin = self.__dict__["_python_twin"] = kernel(copy)
        return twin


def callee(func: Callable) -> Any:
    """A `kernel` that kernels call, without the Python wrapper (see the module docstring);
    as `@callee`."""
    if config.DISABLE_JIT:
        return func
    options = {k: v for k, v in OPTIONS.items() if k != "cache"}
    dispatcher = _Callee(
        py_func=func,
        locals={},
        targetoptions={"nopython": True, "no_cpython_wrapper": True, **options},
    )
    dispatcher.enable_caching()
    return dispatcher
