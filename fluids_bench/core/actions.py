"""One action checker for every env of the suite.

`check_action` refuses, with a `ValueError` naming where, the action and the space, what an
env must not coerce: strings, bools, complex numbers and objects; NaN and infinities; a shape
other than the space's (`(1, n)` is not `(n,)`); and, for a `Discrete` space, anything but
an integer (Python or numpy, not a bool) in range. Box values out of bounds are returned as
given: each env clips (or not) as its card says.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
from gymnasium import spaces


def check_discrete_action(where: str, space: spaces.Discrete, action: Any, name: str) -> int:
    """`action` as a Python int: an integer (`int`, `np.int64`, a 0-d integer array; not a
    bool, a float or `np.float64(1.0)`) in `[start, start + n)`."""
    start, n = int(space.start), int(space.n)
    if isinstance(action, np.ndarray) and action.shape == () and action.dtype.kind in "iu":
        action = action[()]
    if isinstance(action, numbers.Integral) and not isinstance(action, bool | np.bool_):
        value = int(action)
        if start <= value < start + n:
            return value
    raise ValueError(
        f"{where}: {name} is {action!r}; allowed: an integer in [{start}, {start + n}) "
        f"(action space {space})"
    )


def check_box_action(where: str, space: spaces.Box, action: Any, name: str) -> np.ndarray:
    """`action` as a float64 array of the space's shape: real numbers (ints or floats; strings,
    bools, complex numbers and objects are refused, never coerced), finite, of exactly the
    space's shape. Not clipped."""
    a = action if isinstance(action, np.ndarray) else np.asarray(action)
    if a.dtype.kind not in "iuf":  # "0.5", True, 1j, objects: a mistake, not a number to coerce
        raise ValueError(
            f"{where}: {name} is {action!r} (dtype {a.dtype}); allowed: an array of "
            f"{math.prod(space.shape)} real numbers (int or float) in [{space.low.min()}, "
            f"{space.high.max()}] (action space {space})"
        )
    if a.shape != space.shape:
        raise ValueError(
            f"{where}: {name} has shape {a.shape}; allowed: {space.shape} (action space {space})"
        )
    a = np.asarray(a, dtype=np.float64)
    if a.size <= 8:  # a handful of numbers: Python floats cost less than numpy calls
        finite = all(map(math.isfinite, a.reshape(-1).tolist()))
    else:
        finite = bool(np.isfinite(a).all())
    if not finite:
        raise ValueError(
            f"{where}: {name} {a.tolist()} is not finite; allowed: finite numbers "
            f"(action space {space})"
        )
    return a


def check_action(where: str, space: spaces.Space, action: Any, name: str = "action") -> Any:
    """`action` as the env uses it (a Python int for `Discrete`, a float64 array of the
    space's shape for `Box`), or a `ValueError` naming `where`, `name`, the value and the
    space."""
    if isinstance(space, spaces.Discrete):
        return check_discrete_action(where, space, action, name)
    if isinstance(space, spaces.Box):
        return check_box_action(where, space, action, name)
    raise TypeError(f"{where}: no action check for {type(space).__name__} spaces")
