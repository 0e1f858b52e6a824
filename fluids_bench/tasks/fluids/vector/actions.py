"""The batch of actions a FLUIDS vector env takes: one action per world, checked all at once.

The checks are the scalar env's (`fluids_bench.core.actions`) over the whole batch, so a bad
batch is refused before any world moves: strings, bools, complex numbers and objects; a shape
other than `(num_envs, *single_shape)`; NaN and infinities; a `Discrete` action that is not
an integer in range. Box values out of bounds pass (each world clips, as the scalar env does).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces


def check_batch(where: str, single: spaces.Space, n: int, actions: Any) -> np.ndarray:
    """`actions` as an array of `n` actions of `single`'s space, or a `ValueError` naming
    `actions`, the problem and what is allowed."""
    a = actions if isinstance(actions, np.ndarray) else np.asarray(actions)
    if isinstance(single, spaces.Discrete):
        start, stop = int(single.start), int(single.start + single.n)
        if a.dtype.kind not in "iu" or a.shape != (n,):
            raise ValueError(
                f"{where}: actions is {actions!r} (dtype {a.dtype}, shape {a.shape}); "
                f"allowed: {_discrete_allowed(start, stop, n)}"
            )
        bad = np.flatnonzero((a < start) | (a >= stop))
        if len(bad):
            raise ValueError(
                f"{where}: actions[{bad[0]}] is {a[bad[0]]}; allowed: "
                f"{_discrete_allowed(start, stop, n)}"
            )
        return a
    shape = (n, *single.shape)
    if a.dtype.kind not in "iuf":  # "0.5", True, 1j, objects: a mistake, not a number
        raise ValueError(
            f"{where}: actions has dtype {a.dtype}; allowed: {_box_allowed(single, shape)}"
        )
    if a.shape != shape:
        raise ValueError(
            f"{where}: actions has shape {a.shape}; allowed: {_box_allowed(single, shape)}"
        )
    finite = np.isfinite(a)
    if not finite.all():
        finite = finite.reshape(n, -1).all(axis=1)
        i = int(np.flatnonzero(~finite)[0])
        raise ValueError(
            f"{where}: actions[{i}] {a[i].tolist()} is not finite; allowed: finite numbers "
            f"(single action space {single})"
        )
    return a


# (the messages are built only on failure: a space's repr costs more than the checks)
def _discrete_allowed(start: int, stop: int, n: int) -> str:
    return f"{n} integers in [{start}, {stop}), one per world (shape ({n},))"


def _box_allowed(single: spaces.Box, shape: tuple[int, ...]) -> str:
    return (
        f"an array of shape {shape} of real numbers (int or float), one action per world "
        f"(single action space {single})"
    )
