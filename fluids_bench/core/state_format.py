"""The safe state format: an object graph as JSON plus numpy arrays, never a pickle.

A state (what an env's snapshot holds, what a dataset stores) is written as an `.npz` archive
read back with `allow_pickle=False`: a `__meta__` entry (UTF-8 JSON: the header, the object
tree and a table of the arrays, each a dtype, a shape and a byte offset) and a `data` entry
(the arrays' bytes, one after the other). Arrays hold numbers or bools only. Nothing in it
names a function to call.

The tree is plain JSON. `None`, booleans, integers and strings stand for themselves, every other
value is an object with one tag:

| tag | value |
|---|---|
| `float` | `"nan"`, `"inf"` or `"-inf"` (finite floats are JSON numbers) |
| `list`, `tuple`, `set`, `frozenset` | the items |
| `dict`, `odict` | `[key, value]` pairs (`odict`: a `collections.OrderedDict`) |
| `array`, `scalar`, `bytes` | the index of an array in the table (an array, a 0-d array, uint8 bytes) |
| `complex` | `[real, imag]` |
| `generator` | a numpy `Generator`: its bit generator's name, state and seed sequence |
| `object` | `[class, state]`: an instance of a class of this package |
| `static` | the name of an object the restoring env supplies (a compiled layout) |
| `ref` | the number of a list, dict, set, array or object met before (shared stays shared) |
| `absent` | an attribute the env did not have yet |

Reading rebuilds objects only of classes defined in `fluids_bench` modules that are already
imported (looked up by name, never imported), through `cls.__new__` and the class's own
`__setstate__` (or its `__dict__`): no other callable is ever named by the data. Damaged data
raises [`StateFormatError`][fluids_bench.core.state_format.StateFormatError], a `ValueError`
that says what is wrong and where.
"""

from __future__ import annotations

import collections
import copyreg
import io
import json
import math
import sys
import zipfile
from typing import Any

import numpy as np

MAGIC = "fluids-bench-state"
META = "__meta__"
# numpy bit generators a snapshot may hold (name -> class)
BIT_GENERATORS = {
    cls.__name__: cls
    for cls in (np.random.PCG64, np.random.PCG64DXSM, np.random.MT19937, np.random.Philox)
}
BIT_GENERATORS["SFC64"] = np.random.SFC64
PACKAGE_PREFIX = "fluids_bench."
ABSENT = object()  # an attribute the env does not have (yet)


class StateFormatError(ValueError):
    """Stored state data that cannot be read: damaged, of another format, or with fields that
    do not fit the env restoring it."""


# -- writing ----------------------------------------------------------------------------------


class Encoder:
    """Turns an object graph into a JSON tree and a list of arrays (see the module docstring).

    `static` maps `id(obj)` to a name for objects stored by name only."""

    def __init__(self, static: dict[int, str] | None = None) -> None:
        self.static = static or {}
        self.arrays: list[np.ndarray] = []
        self.memo: dict[int, int] = {}
        self.keep: list[Any] = []  # memoised objects stay alive while encoding (stable ids)

    def _array(self, array: np.ndarray) -> int:
        self.arrays.append(array)
        return len(self.arrays) - 1

    def _remember(self, obj: Any, node: dict) -> dict:
        node["id"] = len(self.keep)
        self.memo[id(obj)] = len(self.keep)
        self.keep.append(obj)
        return node

    def encode(self, obj: Any, where: str = "state") -> Any:
        if obj is None or type(obj) in (bool, int, str):
            return obj
        if type(obj) is float:
            return obj if math.isfinite(obj) else {"float": repr(obj)}
        if id(obj) in self.static:
            return {"static": self.static[id(obj)]}
        if id(obj) in self.memo:
            return {"ref": self.memo[id(obj)]}
        if obj is ABSENT:
            return {"absent": True}
        kind = type(obj)
        if kind is tuple:
            return {"tuple": [self.encode(v, f"{where}[{i}]") for i, v in enumerate(obj)]}
        if kind is complex:
            return {"complex": [self.encode(obj.real), self.encode(obj.imag)]}
        if kind is bytes:
            return {"bytes": self._array(np.frombuffer(obj, dtype=np.uint8))}
        if kind is np.ndarray:
            if obj.dtype.hasobject or obj.dtype.names is not None:
                raise StateFormatError(f"{where}: arrays of dtype {obj.dtype} cannot be stored")
            return self._remember(obj, {"array": self._array(obj)})
        if isinstance(obj, np.generic):
            return {"scalar": self._array(np.asarray(obj))}
        if kind in (list, set, frozenset):
            node = self._remember(obj, {kind.__name__: None})
            items = obj if kind is list else sorted(obj, key=repr)
            node[kind.__name__] = [self.encode(v, f"{where}[{i}]") for i, v in enumerate(items)]
            return node
        if kind in (dict, collections.OrderedDict):
            tag = "dict" if kind is dict else "odict"
            node = self._remember(obj, {tag: None})
            node[tag] = [
                [self.encode(k, where), self.encode(v, f"{where}[{k!r}]")] for k, v in obj.items()
            ]
            return node
        if kind is np.random.Generator:
            return self._remember(obj, {"generator": self._generator(obj, where)})
        return self._object(obj, where)

    def _generator(self, rng: np.random.Generator, where: str) -> Any:
        bit_generator = rng.bit_generator
        name = type(bit_generator).__name__
        if BIT_GENERATORS.get(name) is not type(bit_generator):
            raise StateFormatError(f"{where}: bit generator {name} cannot be stored")
        seq = bit_generator.seed_seq
        seed_seq = None
        if isinstance(seq, np.random.SeedSequence):
            seed_seq = {
                "entropy": seq.entropy,
                "spawn_key": list(seq.spawn_key),
                "pool_size": seq.pool_size,
                "n_children_spawned": seq.n_children_spawned,
            }
        return [name, self.encode(bit_generator.state, where), self.encode(seed_seq, where)]

    def _object(self, obj: Any, where: str) -> Any:
        cls = type(obj)
        name = class_name(cls)
        if not cls.__module__.startswith(PACKAGE_PREFIX):
            raise StateFormatError(
                f"{where}: a {name} cannot be stored (only plain data, numpy arrays and "
                f"{PACKAGE_PREFIX}* objects can)"
            )
        reduced = obj.__reduce_ex__(4)
        if not isinstance(reduced, tuple) or reduced[0] is not copyreg.__newobj__:
            raise StateFormatError(f"{where}: a {name} does not store as plain state")
        state = reduced[2] if len(reduced) > 2 else None
        node = self._remember(obj, {"object": None})
        node["object"] = [name, self.encode(state, f"{where}.{cls.__name__}")]
        return node


def class_name(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


# -- reading ----------------------------------------------------------------------------------


def find_class(name: Any, where: str) -> type:
    """The class `module:qualname` of this package, from a module already imported."""
    if not isinstance(name, str) or name.count(":") != 1:
        raise StateFormatError(f"{where}: {name!r} is not a class name (module:qualname)")
    module_name, qualname = name.split(":")
    module = sys.modules.get(module_name)
    if not module_name.startswith(PACKAGE_PREFIX) or module is None:
        raise StateFormatError(
            f"{where}: class {name} is not allowed (allowed: classes of imported "
            f"{PACKAGE_PREFIX}* modules)"
        )
    obj: Any = module
    for part in qualname.split("."):
        obj = getattr(obj, part, None) if not part.startswith("<") else None
    if not isinstance(obj, type) or obj.__module__ != module_name:
        raise StateFormatError(f"{where}: there is no class {name}")
    return obj


class Decoder:
    """Rebuilds the object graph an [`Encoder`][fluids_bench.core.state_format.Encoder] wrote.

    `static` maps names to the objects the restoring env supplies; `schema` (optional) checks
    every object's fields (see [`Schema`][fluids_bench.core.state_format.Schema])."""

    def __init__(
        self, arrays: list[np.ndarray], static: dict[str, Any], schema: Schema | None = None
    ) -> None:
        self.arrays, self.static, self.schema = arrays, static, schema
        self.memo: dict[int, Any] = {}
        self.used: set[int] = set()

    def _entry(self, index: Any, where: str) -> np.ndarray:
        if type(index) is not int or not 0 <= index < len(self.arrays):
            raise StateFormatError(f"{where}: array entry {index!r} does not exist")
        self.used.add(index)
        return self.arrays[index]

    def _remember(self, node: dict, value: Any, where: str) -> Any:
        number = node.get("id")
        if type(number) is not int or number in self.memo:
            raise StateFormatError(f"{where}: bad or repeated object number {number!r}")
        self.memo[number] = value
        return value

    def decode(self, node: Any, where: str = "state") -> Any:
        if node is None or type(node) in (bool, int, str):
            return node
        if type(node) is float:
            return node
        if type(node) is not dict or not node:
            raise StateFormatError(f"{where}: {type(node).__name__} is not a state value")
        tags = [k for k in node if k != "id"]
        if len(tags) != 1:
            raise StateFormatError(f"{where}: a value has tags {sorted(tags)}; expected one")
        tag = tags[0]
        value = node[tag]
        method = getattr(self, f"_decode_{tag}", None)
        if method is None:
            raise StateFormatError(f"{where}: unknown value tag {tag!r}")
        return method(node, value, where)

    def _items(self, value: Any, where: str) -> list:
        if type(value) is not list:
            raise StateFormatError(f"{where}: expected a list of items, got {type(value).__name__}")
        return value

    def _decode_float(self, node: dict, value: Any, where: str) -> float:
        if value not in ("nan", "inf", "-inf"):
            raise StateFormatError(f"{where}: float {value!r} is not nan, inf or -inf")
        return float(value)

    def _decode_complex(self, node: dict, value: Any, where: str) -> complex:
        parts = [self.decode(v, where) for v in self._items(value, where)]
        if len(parts) != 2 or not all(type(p) in (int, float) for p in parts):
            raise StateFormatError(f"{where}: a complex needs [real, imag]")
        return complex(*parts)

    def _decode_tuple(self, node: dict, value: Any, where: str) -> tuple:
        return tuple(
            self.decode(v, f"{where}[{i}]") for i, v in enumerate(self._items(value, where))
        )

    def _decode_list(self, node: dict, value: Any, where: str) -> list:
        out = self._remember(node, [], where)
        out.extend(self.decode(v, f"{where}[{i}]") for i, v in enumerate(self._items(value, where)))
        return out

    def _decode_set(self, node: dict, value: Any, where: str) -> set:
        out = self._remember(node, set(), where)
        try:
            out.update(self.decode(v, where) for v in self._items(value, where))
        except TypeError as error:
            raise StateFormatError(f"{where}: a set holds an unhashable value ({error})") from None
        return out

    def _decode_frozenset(self, node: dict, value: Any, where: str) -> frozenset:
        return self._remember(node, frozenset(self._decode_set({"id": -1}, value, where)), where)

    def _decode_dict(self, node: dict, value: Any, where: str, kind: type = dict) -> dict:
        out = self._remember(node, kind(), where)
        for pair in self._items(value, where):
            if type(pair) is not list or len(pair) != 2:
                raise StateFormatError(f"{where}: a dict item is not a [key, value] pair")
            key = self.decode(pair[0], where)
            try:
                out[key] = self.decode(pair[1], f"{where}[{key!r}]")
            except TypeError as error:
                raise StateFormatError(f"{where}: unhashable dict key ({error})") from None
        return out

    def _decode_odict(self, node: dict, value: Any, where: str) -> dict:
        return self._decode_dict(node, value, where, collections.OrderedDict)

    def _decode_array(self, node: dict, value: Any, where: str) -> np.ndarray:
        return self._remember(node, self._entry(value, where), where)

    def _decode_scalar(self, node: dict, value: Any, where: str) -> np.generic:
        array = self._entry(value, where)
        if array.ndim != 0:
            raise StateFormatError(f"{where}: a scalar entry has shape {array.shape}")
        return array[()]

    def _decode_bytes(self, node: dict, value: Any, where: str) -> bytes:
        array = self._entry(value, where)
        if array.dtype != np.uint8 or array.ndim != 1:
            raise StateFormatError(f"{where}: a bytes entry is {array.dtype} {array.shape}")
        return array.tobytes()

    def _decode_static(self, node: dict, value: Any, where: str) -> Any:
        if type(value) is not str or value not in self.static:
            raise StateFormatError(
                f"{where}: the state refers to {value!r}, which this env does not have "
                f"(allowed: {sorted(self.static)})"
            )
        return self.static[value]

    def _decode_ref(self, node: dict, value: Any, where: str) -> Any:
        if type(value) is not int or value not in self.memo:
            raise StateFormatError(f"{where}: reference {value!r} to no earlier value")
        return self.memo[value]

    def _decode_absent(self, node: dict, value: Any, where: str) -> Any:
        return ABSENT

    def _decode_generator(self, node: dict, value: Any, where: str) -> np.random.Generator:
        items = self._items(value, where)
        if len(items) != 3 or items[0] not in BIT_GENERATORS:
            raise StateFormatError(
                f"{where}: a generator needs [bit generator, state, seed sequence] with a bit "
                f"generator among {sorted(BIT_GENERATORS)}"
            )
        cls = BIT_GENERATORS[items[0]]
        state, seq = self.decode(items[1], where), self.decode(items[2], where)
        try:
            seed_seq = None if seq is None else np.random.SeedSequence(**seq)
            bit_generator = cls(seed_seq)
            bit_generator.state = state
        except (TypeError, ValueError, KeyError, OverflowError) as error:
            raise StateFormatError(f"{where}: bad random generator state ({error})") from None
        return self._remember(node, np.random.Generator(bit_generator), where)

    def _decode_object(self, node: dict, value: Any, where: str) -> Any:
        items = self._items(value, where)
        if len(items) != 2:
            raise StateFormatError(f"{where}: an object needs [class, state]")
        cls = find_class(items[0], where)
        obj = self._remember(node, cls.__new__(cls), where)
        here = where
        state = self.decode(items[1], here)
        if self.schema is not None:
            self.schema.check(items[0], state, here)
        try:
            setstate = getattr(cls, "__setstate__", None)
            if setstate is not None:
                obj.__setstate__(state)
            elif type(state) is dict:
                obj.__dict__.update(state)
            elif state is not None:
                raise StateFormatError(f"{where}: a {cls.__name__}'s state must be a dict")
        except StateFormatError:
            raise
        except Exception as error:  # the class's own __setstate__ refused the data
            raise StateFormatError(
                f"{here}: the stored fields do not rebuild a {cls.__name__} "
                f"({type(error).__name__}: {error})"
            ) from None
        return obj


# -- field checks -----------------------------------------------------------------------------


def _kind(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return ("array", value.dtype.str, value.ndim, value.shape[1:])
    return None


class Schema:
    """What the objects of an env's state look like, learnt from reference states of a fresh
    env of the same class and kwargs: for each class, the fields every reference had
    (required), the fields any had (allowed), and each array field's dtype and trailing shape.

    [`check`][fluids_bench.core.state_format.Schema.check] refuses a stored object with a
    missing field, an extra field, an array of another dtype, rank or trailing shape, or two
    arrays of different lengths that had the same length (at least 1) in every reference."""

    def __init__(self) -> None:
        self.required: dict[str, set] = {}
        self.allowed: dict[str, set] = {}
        self.arrays: dict[str, dict[Any, Any]] = {}
        self.linked: dict[str, set[tuple[str, str]]] = {}

    def learn(self, state: Any, skip: set[int] = frozenset()) -> None:
        """Add the objects reachable from `state` (a live object graph), less those whose id
        is in `skip`."""
        seen: set[int] = set(skip)
        stack = [state]
        while stack:
            obj = stack.pop()
            if id(obj) in seen or obj is None or type(obj) in (bool, int, float, str):
                continue
            seen.add(id(obj))
            if type(obj) in (list, tuple, set, frozenset):
                stack.extend(obj)
            elif isinstance(obj, dict):
                stack.extend(obj.values())
            elif type(obj).__module__.startswith(PACKAGE_PREFIX):
                reduced = obj.__reduce_ex__(4)
                fields = reduced[2] if len(reduced) > 2 else None
                if type(fields) is dict:
                    self._learn_fields(class_name(type(obj)), fields)
                    stack.extend(fields.values())

    def _learn_fields(self, name: str, fields: dict) -> None:
        keys = set(fields)
        self.required[name] = self.required.get(name, keys) & keys
        self.allowed[name] = self.allowed.get(name, set()) | keys
        # arrays whose first dimension (at least 1) was the same in every reference: the
        # same count of things (agents, lights), which a stored state must keep equal too
        lengths = {k: v.shape[0] for k, v in fields.items() if isinstance(v, np.ndarray) and v.ndim}
        pairs = {(a, b) for a in lengths for b in lengths if a < b and lengths[a] == lengths[b]}
        pairs = {(a, b) for a, b in pairs if lengths[a] >= 1}
        self.linked[name] = self.linked.get(name, pairs) & pairs
        self.__dict__.pop("_group_cache", None)
        arrays = self.arrays.setdefault(name, {})
        for key, value in fields.items():
            kind = _kind(value)
            if kind is None:
                continue
            if arrays.get(key, kind) != kind:
                kind = ("array", None, None, None)  # seen with several forms: not checked
            arrays[key] = kind

    def check(self, name: str, fields: Any, where: str) -> None:
        """Refuse `fields` (a stored object's decoded state) that do not fit class `name`."""
        if name not in self.required:
            return  # a class the references never held: allowed, not checked
        if type(fields) is not dict:
            raise StateFormatError(f"{where}: the stored state is not a dict of fields")
        missing = sorted(self.required[name] - set(fields), key=str)
        if missing:
            raise StateFormatError(f"{where}: missing field(s) {missing}")
        extra = sorted(set(fields) - self.allowed[name], key=str)
        if extra:
            raise StateFormatError(f"{where}: unexpected field(s) {extra}")
        for key, kind in self.arrays[name].items():
            value = fields.get(key)
            if kind[1] is None or not isinstance(value, np.ndarray):
                continue
            if value.dtype.str != kind[1] or (value.ndim, value.shape[1:]) != kind[2:]:
                expected = "()" if kind[2] == 0 else str(("n", *kind[3])).replace("'", "")
                raise StateFormatError(
                    f"{where}.{key}: an array of dtype {value.dtype} and shape {value.shape}; "
                    f"expected dtype {np.dtype(kind[1])} and shape {expected}"
                )
        for group in self._groups(name):
            present = [
                (k, fields[k])
                for k in group
                if isinstance(fields.get(k), np.ndarray) and fields[k].ndim
            ]
            if len({v.shape[0] for _, v in present}) > 1:
                shown = ", ".join(f"{k!r} {v.shape}" for k, v in present)
                raise StateFormatError(
                    f"{where}: arrays {shown} must have the same length (first dimension)"
                )

    def _groups(self, name: str) -> list[list[str]]:
        """The linked fields of class `name` as groups of equal length (cached)."""
        cache = self.__dict__.setdefault("_group_cache", {})
        if name not in cache:
            parent: dict[str, str] = {}

            def root(k: str) -> str:
                while parent.setdefault(k, k) != k:
                    k = parent[k]
                return k

            for a, b in self.linked[name]:
                parent[root(a)] = root(b)
            groups: dict[str, list[str]] = {}
            for k in parent:
                groups.setdefault(root(k), []).append(k)
            cache[name] = [sorted(g) for g in groups.values() if len(g) > 1]
        return cache[name]


# -- the archive ------------------------------------------------------------------------------

DATA = "data"
ALIGN = 16  # each array starts at a multiple of this many bytes of the data entry
ARRAY_KINDS = "biufc"  # bool, integers, floats, complex: the only dtypes stored


def _dtype(text: Any, what: str) -> np.dtype:
    try:
        dtype = np.dtype(text) if isinstance(text, str) else None
    except TypeError:
        dtype = None
    if dtype is None or dtype.kind not in ARRAY_KINDS or dtype.fields is not None:
        raise StateFormatError(f"{what}: array dtype {text!r} is not allowed (numbers and bools)")
    return dtype


def pack(meta: dict[str, Any], arrays: list[np.ndarray] = (), compress: bool = False) -> bytes:
    """An `.npz` archive's bytes: `meta` as JSON in `__meta__` (with a table of the arrays:
    dtype, shape, byte offset) and the arrays' bytes one after the other in `data` (deflated
    with `compress`)."""
    table, chunks, offset = [], [], 0
    for array in arrays:
        array = np.asarray(array)
        dtype = _dtype(array.dtype.str, "pack")
        raw = np.ascontiguousarray(array).tobytes()
        table.append([dtype.str, list(array.shape), offset])
        padding = -len(raw) % ALIGN
        chunks += [raw, b"\0" * padding]
        offset += len(raw) + padding
    full = {"format": MAGIC, **meta, "arrays": table}
    text = json.dumps(full, allow_nan=False, separators=(",", ":"))
    entries = {
        META: np.frombuffer(text.encode(), dtype=np.uint8),
        DATA: np.frombuffer(b"".join(chunks), dtype=np.uint8),
    }
    buffer = io.BytesIO()
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with zipfile.ZipFile(buffer, "w", compression=method) as archive:
        for name, array in entries.items():
            # a fixed timestamp: the same state gives the same bytes
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = method
            with archive.open(info, "w", force_zip64=True) as entry:
                np.lib.format.write_array(entry, array, allow_pickle=False)
    return buffer.getvalue()


def unpack(data: Any, what: str = "state") -> tuple[dict[str, Any], list[np.ndarray]]:
    """The meta dict and the arrays of [`pack`][fluids_bench.core.state_format.pack]'s bytes
    (each array a fresh, writeable copy).

    Raises `StateFormatError` naming `what` when `data` is empty, truncated, garbled or not of
    this format (it is read with `allow_pickle=False`: it never runs code)."""
    if not isinstance(data, bytes | bytearray | memoryview):
        raise StateFormatError(f"{what}: expected bytes, got {type(data).__name__}")
    if len(data) == 0:
        raise StateFormatError(f"{what} is empty (0 bytes)")
    damaged = f"{what} is damaged or not a fluids-bench state"
    try:
        with np.load(io.BytesIO(bytes(data)), allow_pickle=False) as archive:
            if sorted(archive.files) != sorted([META, DATA]):
                raise StateFormatError(
                    f"{damaged}: entries {sorted(archive.files)}, expected {sorted([META, DATA])}"
                )
            raw, blob = archive[META], archive[DATA]
    except StateFormatError:
        raise
    except (ValueError, OSError, EOFError, KeyError, zipfile.BadZipFile, RuntimeError) as error:
        raise StateFormatError(
            f"{damaged} ({type(error).__name__}: {error}); expected an .npz written by fluids-bench"
        ) from None
    if raw.dtype != np.uint8 or blob.dtype != np.uint8 or raw.ndim != 1 or blob.ndim != 1:
        raise StateFormatError(f"{damaged}: its entries are not bytes")
    try:
        meta = json.loads(raw.tobytes().decode())
    except (UnicodeDecodeError, ValueError) as error:
        raise StateFormatError(f"{damaged}: its {META} is not valid JSON ({error})") from None
    if type(meta) is not dict or meta.get("format") != MAGIC:
        raise StateFormatError(f"{damaged} (format {MAGIC!r} expected)")
    table = meta.pop("arrays", None)
    if type(table) is not list:
        raise StateFormatError(f"{damaged}: no table of arrays")
    arrays = []
    buffer = blob.tobytes()
    for i, row in enumerate(table):
        if (
            type(row) is not list
            or len(row) != 3
            or type(row[1]) is not list
            or not all(type(n) is int and n >= 0 for n in row[1])
            or type(row[2]) is not int
        ):
            raise StateFormatError(f"{damaged}: array {i}'s entry {row!r} is malformed")
        dtype, shape, offset = _dtype(row[0], what), tuple(row[1]), row[2]
        count = math.prod(shape)
        if offset < 0 or offset + count * dtype.itemsize > len(buffer):
            raise StateFormatError(f"{damaged}: array {i} lies outside the data")
        array = np.frombuffer(buffer, dtype=dtype, count=count, offset=offset)
        arrays.append(array.reshape(shape).copy())
    return meta, arrays
