"""Batched infos in Gymnasium's vector layout, built key by key for all worlds at once.

``batch_infos(infos, n)`` gives what ``VectorEnv._add_info`` gives when called world after world
(what ``SyncVectorEnv`` returns): every key holds an array over the ``n`` worlds with a boolean
mask ``_key`` saying which worlds have it. A key's array is typed by the first world that has it:
Python ``int``/``float``/``bool`` and numpy numbers as that dtype, numpy arrays stacked as
``(n, *shape)`` of their dtype, dicts batched recursively, anything else (lists, strings) as an
object array with ``None`` where a world lacks the key. ``final_obs`` is always an object array.
"""

from __future__ import annotations

from typing import Any

import numpy as np

_SCALARS = (int, float, bool)


def _empty(value: Any, n: int) -> np.ndarray:
    """The array ``_add_info`` creates for a key whose first value is ``value``."""
    if type(value) in _SCALARS or issubclass(type(value), np.number):
        return np.zeros(n, dtype=type(value))
    if isinstance(value, np.ndarray):
        return np.zeros((n, *value.shape), dtype=value.dtype)
    return np.full(n, fill_value=None, dtype=object)


def batch_infos(infos: list[dict[str, Any] | None], n: int) -> dict[str, Any]:
    """The vector info of ``infos`` (one dict per world, ``None`` for a world without one)."""
    keys: dict[str, None] = {}  # first appearance, world by world (as _add_info inserts them)
    for info in infos:
        if info:
            keys.update(dict.fromkeys(info))
    out: dict[str, Any] = {}
    for key in keys:
        present = [i for i, info in enumerate(infos) if info and key in info]
        mask = np.zeros(n, dtype=np.bool_)
        mask[present] = True
        first = infos[present[0]][key]
        if isinstance(first, dict) and key != "final_obs":
            out[key] = batch_infos([info.get(key) if info else None for info in infos], n)
        else:
            array = np.full(n, None, dtype=object) if key == "final_obs" else _empty(first, n)
            for i in present:
                array[i] = infos[i][key]
            out[key] = array
        out[f"_{key}"] = mask
    return out
