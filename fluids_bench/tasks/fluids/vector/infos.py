"""Batched infos in Gymnasium's vector layout, built key by key for all worlds at once.

`batch_infos(infos, n)` gives what `VectorEnv._add_info` gives when called world after world
(what `SyncVectorEnv` returns): every key holds an array over the `n` worlds with a boolean
mask `_key` saying which worlds have it. A key's array is typed by the first world that has it:
Python `int`/`float`/`bool` and numpy numbers as that dtype, numpy arrays stacked as
`(n, *shape)` of their dtype, dicts batched recursively, anything else (lists, strings) as an
object array with `None` where a world lacks the key. `final_obs` is always an object array.

`step_infos` builds the same result for a step in which every world has the scalar env's
info keys, from `fluids_bench.tasks.fluids.core.infos.ego_info` of the batch's rows (the
builder `FluidsEnv._info` calls with one world) instead of per-world dicts.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.tasks.fluids.core.infos import ego_info

_SCALARS = (int, float, bool)


def _empty(value: Any, n: int) -> np.ndarray:
    """The array `_add_info` creates for a key whose first value is `value`."""
    kind = type(value)
    if kind in _SCALARS or issubclass(kind, np.number):
        return np.zeros(n, dtype=kind)
    if kind is np.ndarray:
        return np.zeros((n, *value.shape), dtype=value.dtype)
    return np.empty(n, dtype=object)  # None everywhere


@functools.lru_cache(maxsize=8)
def _all_true(n: int) -> np.ndarray:
    return np.ones(n, dtype=np.bool_)  # copied for each key (np.ones costs more than a copy)


def batch_infos(infos: list[dict[str, Any] | None] | dict[int, dict], n: int) -> dict[str, Any]:
    """The vector info of `infos`: one dict per world (`None` for a world without one), or
    `{world: dict}` for the worlds with one."""
    # one pass: each key's (world, value) pairs, keys in first appearance world by world (the
    # order _add_info inserts them)
    by_key: dict[str, list[tuple[int, Any]]] = {}
    for i, info in sorted(infos.items()) if isinstance(infos, dict) else enumerate(infos):
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


def step_infos(
    envs, worlds, faults, lights, own: dict[int, dict], events: list, labels=None
) -> dict:
    """`batch_infos` of `FluidsEnv._info` of every env, merged with `own` (the other
    keys of the worlds that have some, e.g. `is_success`, or a whole info for a world that
    was reset: its values replace the batched ones).

    `worlds` and `faults` are the envs' bound
    `WorldBatch` and `FaultBatch`, `lights`
    each world's light states (B, L) and `events` each world's new collisions. `labels`:
    (labels (B, ...), mask) with the label of each world where the mask is set (from
    `core.labels.label_rows`); the other worlds' labels come from their envs."""
    n, w = len(envs), envs[0].world
    out: dict[str, Any] = {}
    if labels is None:
        label = _stack([env.supervisor_action() for env in envs])
    else:
        label, known = labels
        label = label.copy()
        for i in (~known).nonzero()[0].tolist():
            label[i] = envs[i].supervisor_action()
    # each world's own list (empty, or its new collisions with their fault labels)
    collisions = np.fromiter(events, dtype=object, count=n)
    for i in worlds.hit.nonzero()[0].tolist():
        collisions[i] = envs[i].faults.annotate(events[i])
    fields = ego_info(
        label, collisions, worlds["reached"], worlds["route"], w, faults["ran_red"][:, 0],
        faults["failed_to_yield"][:, 0], lights,
    )  # fmt: skip
    for key, value in fields.items():  # every world has every key (the lights: a dict)
        out[key] = _with_masks(value, n) if isinstance(value, dict) else value
        out[f"_{key}"] = _all_true(n).copy()
    for key, value in batch_infos(own, n).items():  # keys only some worlds have
        out.setdefault(key, value)
    for i, info in own.items():  # a whole info of its own (a reset world): its values
        if SUPERVISOR_ACTION_KEY in info:
            _overwrite(out, info, i)
    return out


def _with_masks(columns: dict[str, np.ndarray], n: int) -> dict[str, np.ndarray]:
    """`columns` (every world has each) with each key's `_key` mask, as `batch_infos` lays a
    nested dict out."""
    out = {}
    for key, column in columns.items():
        out[key], out[f"_{key}"] = column, _all_true(n).copy()
    return out


def _stack(labels: list) -> np.ndarray:
    """The labels as `batch_infos` batches them (ints, or arrays stacked)."""
    first = labels[0]
    if isinstance(first, np.ndarray):
        return np.stack(labels)
    array = _empty(first, len(labels))
    array[:] = labels
    return array


def _overwrite(out: dict, info: dict, i: int) -> None:
    """World `i`'s entries of `out` set to `info`'s (nested dicts too)."""
    for key, value in info.items():
        if isinstance(value, dict):
            _overwrite(out[key], value, i)
        else:
            out[key][i] = value
