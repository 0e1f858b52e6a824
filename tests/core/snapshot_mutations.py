"""Helpers that damage snapshots on purpose (for the snapshot format and fuzz tests)."""

from __future__ import annotations

import copy
from collections.abc import Iterator
from typing import Any

import numpy as np

from fluids_bench.core.snapshot import EnvSnapshot
from fluids_bench.core.state_format import pack, unpack


def repack(saved: EnvSnapshot, edit) -> bytes:
    """`saved`'s bytes after `edit(meta, arrays)` changed its (copied) header and arrays."""
    meta, arrays = unpack(saved.to_bytes())
    meta, arrays = copy.deepcopy(meta), [a.copy() for a in arrays]
    edit(meta, arrays)
    return pack({k: v for k, v in meta.items() if k != "format"}, arrays)


def object_nodes(node: Any, path: str = "state") -> Iterator[tuple[str, dict]]:
    """Every `object` node of a snapshot's field tree, with a readable path."""
    if isinstance(node, dict):
        if "object" in node and isinstance(node["object"], list):
            yield path, node
            yield from object_nodes(node["object"][1], f"{path}<{node['object'][0]}>")
            return
        for tag, value in node.items():
            if tag != "id":
                yield from object_nodes(value, path)
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from object_nodes(value, f"{path}/{i}")


def field_pairs(obj_node: dict) -> list | None:
    """The `[name, value]` pairs of an object node's state (None when it is not a dict)."""
    state = obj_node["object"][1]
    if isinstance(state, dict) and isinstance(state.get("dict"), list):
        return state["dict"]
    return None


def array_fields(obj_node: dict) -> list[tuple[str, int]]:
    """`(field name, array entry)` of an object node's array fields."""
    pairs = field_pairs(obj_node) or []
    return [
        (k, v["array"])
        for k, v in pairs
        if isinstance(k, str) and isinstance(v, dict) and isinstance(v.get("array"), int)
    ]


def mutations(saved: EnvSnapshot) -> Iterator[tuple[str, bytes]]:
    """`(what, damaged bytes)`: every structural damage a stored state can suffer, each of
    which restore must refuse with a clear error."""
    data = saved.to_bytes()
    yield "empty", b""
    for cut in (1, 10, len(data) // 3, len(data) // 2, len(data) - 1):
        yield f"truncated to {cut} bytes", data[:cut]
    rng = np.random.default_rng(0)
    for k in range(8):
        garbled = bytearray(data)
        for i in rng.integers(0, len(data), size=1 + k):
            garbled[i] ^= int(rng.integers(1, 256))
        yield f"garbled ({1 + k} bytes)", bytes(garbled)
    meta, _ = unpack(data)
    top = [k for k, _ in meta["fields"]["dict"]]

    for name in top:
        yield (
            f"top field {name!r} missing",
            repack(saved, lambda m, a, n=name: _drop(m["fields"]["dict"], n)),
        )
    yield "extra top field", repack(saved, lambda m, a: m["fields"]["dict"].append(["bogus", 1]))
    yield "no fields", repack(saved, lambda m, a: m["fields"].update(dict=[]))
    header = [("env_id", "Other-v0")] if saved.env_id is not None else []  # no id: no check
    for key, value in header + [
        ("package_version", "0.0.0"),
        ("format_version", 99),
        ("env_class", "fluids_bench.tasks.gridworld.env:Nope"),
    ]:
        yield (
            f"header {key}={value!r}",
            repack(saved, lambda m, a, k=key, v=value: m.update({k: v})),
        )
    yield "kwargs changed", repack(saved, _change_kwargs)
    for i, (path, node) in enumerate(object_nodes(meta["fields"])):
        pairs = field_pairs(node)
        if pairs is None:
            continue
        for name, _ in pairs[:2]:
            yield (
                f"{path} field {name!r} missing",
                repack(saved, lambda m, a, i=i, n=name: _drop(_nth_pairs(m, i), n)),
            )
        yield (
            f"{path} extra field",
            repack(saved, lambda m, a, i=i: _nth_pairs(m, i).append(["bogus", 1])),
        )
        for name, entry in array_fields(node)[:3]:
            yield (
                f"{path}.{name} dtype changed",
                repack(saved, lambda m, a, e=entry: a.__setitem__(e, _other_dtype(a[e]))),
            )
            yield (
                f"{path}.{name} given another trailing dimension",
                repack(saved, lambda m, a, e=entry: a.__setitem__(e, a[e][..., None])),
            )


def _drop(pairs: list, name: str) -> None:
    pairs[:] = [p for p in pairs if p[0] != name]


def _nth_pairs(meta: dict, i: int) -> list:
    return field_pairs(list(object_nodes(meta["fields"]))[i][1])


def _other_dtype(array: np.ndarray) -> np.ndarray:
    return array.astype(np.float64 if array.dtype == np.float32 else np.float32)


def _change_kwargs(meta: dict, arrays: list) -> None:
    meta["kwargs_hash"] = "0" * 16
