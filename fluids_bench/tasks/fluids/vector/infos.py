"""Batched infos in Gymnasium's vector layout, built key by key for all worlds at once.

``batch_infos(infos, n)`` gives what ``VectorEnv._add_info`` gives when called world after world
(what ``SyncVectorEnv`` returns): every key holds an array over the ``n`` worlds with a boolean
mask ``_key`` saying which worlds have it. A key's array is typed by the first world that has it:
Python ``int``/``float``/``bool`` and numpy numbers as that dtype, numpy arrays stacked as
``(n, *shape)`` of their dtype, dicts batched recursively, anything else (lists, strings) as an
object array with ``None`` where a world lacks the key. ``final_obs`` is always an object array.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

_SCALARS = (int, float, bool)


def _empty(value: Any, n: int) -> np.ndarray:
    """The array ``_add_info`` creates for a key whose first value is ``value``."""
    kind = type(value)
    if kind in _SCALARS or issubclass(kind, np.number):
        return np.zeros(n, dtype=kind)
    if kind is np.ndarray:
        return np.zeros((n, *value.shape), dtype=value.dtype)
    return np.empty(n, dtype=object)  # None everywhere


@functools.lru_cache(maxsize=8)
def _all_true(n: int) -> np.ndarray:
    return np.ones(n, dtype=np.bool_)  # copied for each key (np.ones costs more than a copy)


def batch_infos(infos: list[dict[str, Any] | None], n: int) -> dict[str, Any]:
    """The vector info of ``infos`` (one dict per world, ``None`` for a world without one)."""
    # one pass: each key's (world, value) pairs, keys in first appearance world by world (the
    # order _add_info inserts them)
    by_key: dict[str, list[tuple[int, Any]]] = {}
    for i, info in enumerate(infos):
        if info:
            for key, value in info.items():
                by_key.setdefault(key, []).append((i, value))
    out: dict[str, Any] = {}
    for key, pairs in by_key.items():
        if len(pairs) == n:
            mask = _all_true(n).copy()
        else:
            mask = np.zeros(n, dtype=np.bool_)
            for i, _ in pairs:
                mask[i] = True
        first = pairs[0][1]
        if isinstance(first, dict) and key != "final_obs":
            sub: list[dict | None] = [None] * n
            for i, value in pairs:
                sub[i] = value
            out[key] = batch_infos(sub, n)
        else:
            array = np.empty(n, dtype=object) if key == "final_obs" else _empty(first, n)
            for i, value in pairs:
                array[i] = value
            out[key] = array
        out[f"_{key}"] = mask
    return out
