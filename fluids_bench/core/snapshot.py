"""Snapshots of an env's state: `env.unwrapped.snapshot()` and `restore(snapshot)`.

Every Gymnasium env of the suite mixes in [`SnapshotMixin`][fluids_bench.core.snapshot.SnapshotMixin].
`snapshot()` returns an [`EnvSnapshot`][fluids_bench.core.snapshot.EnvSnapshot]: bytes in the
safe state format of [`fluids_bench.core.state_format`][fluids_bench.core.state_format] (an `.npz`
of arrays plus JSON, read with `allow_pickle=False`, never a pickle) holding a versioned header
(format version, package version, env class, id, construction kwargs and their hash) and
everything the env's future depends on (the simulator, the supervisor's memory where it has
one, the episode counters and `np_random`). `restore(snapshot)` on another env of the same class
and kwargs (built with `gym.make` of the same id, reset with any seed or not reset at all) makes
it continue bit-identically under the same actions: the same observations, rewards,
terminated/truncated flags, infos and supervisor labels. `render_mode` may differ (drawing only
reads).

Restore refuses, with a `ValueError` ([`StateFormatError`][fluids_bench.core.state_format.StateFormatError])
that names what is wrong, a snapshot of another class, id, kwargs, format or package version,
and damaged data: empty, truncated or garbled bytes, a missing or extra field (at the top or in
any object of the state), an array of another dtype or shape. The fields are checked against
reference states of a fresh env of the same class and kwargs (built once per process).

What an env's state is, each env says in `SnapshotMixin._snapshot_fields` (attribute names,
stored together, so objects they share stay shared) and `SnapshotMixin._snapshot_static`
(objects built from the kwargs alone, which reset and step never change, such as a compiled
FLUIDS layout: stored by name, never copied, and taken from the restoring env). An env whose
state needs more (MuJoCo's `MjData`) overrides `_snapshot_state` / `_restore_state`.

`env.unwrapped.snapshot()` covers the env, not the wrappers `gym.make` puts around it:
`TimeLimit` counts the episode's steps itself. [`snapshot`][fluids_bench.core.snapshot.snapshot]
and [`restore`][fluids_bench.core.snapshot.restore] take a wrapped env and also carry the
wrappers' counters (`TimeLimit`'s elapsed steps, the `OrderEnforcing` reset flag), so
truncation happens at the same step too; `WrappedSnapshot.to_bytes()` / `from_bytes()` store it.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import json
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from fluids_bench.core.state_format import (
    ABSENT,
    Decoder,
    Encoder,
    Schema,
    StateFormatError,
    class_name,
    pack,
    unpack,
)
from fluids_bench.core.version import __version__

# the layout of the data: bump when what a snapshot holds changes shape
FORMAT_VERSION = 1
# Gymnasium's own per-env randomness (set by Env.reset(seed=...)): part of every snapshot
RNG_FIELDS = ("_np_random", "_np_random_seed")
# construction kwargs that do not change what the env computes
IGNORED_KWARGS = ("render_mode",)
# wrapper attributes that are episode state (wrapper class name -> attribute names)
WRAPPER_FIELDS = {
    "TimeLimit": ("_elapsed_steps",),
    "OrderEnforcing": ("_has_reset",),
    "PassiveEnvChecker": (),
}
# how many steps of a fresh env the field checks learn from (after reset)
REFERENCE_STEPS = 3
_SCHEMAS: dict[tuple[str, str], tuple[frozenset, Schema]] = {}

__all__ = [
    "EnvSnapshot",
    "SnapshotMixin",
    "StateFormatError",
    "WrappedSnapshot",
    "restore",
    "snapshot",
]


def package_version() -> str:
    return __version__


def _plain(value: Any) -> Any:
    """`value` with numpy scalars as Python numbers and tuples as lists (for comparison)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return value


def kwargs_hash(kwargs: dict[str, Any]) -> str:
    """A short hash of construction kwargs (sha256 of their sorted JSON)."""
    text = json.dumps(kwargs, sort_keys=True, default=repr, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True, eq=False)
class EnvSnapshot:
    """The state of one env at one moment, as bytes of the safe state format.

    `EnvSnapshot(data)` (or `EnvSnapshot.from_bytes(data)`) reads and checks the header of
    stored bytes (raising `StateFormatError` when they are empty, damaged or not a snapshot);
    `to_bytes()` gives them back. `env_class` (`module:qualname`), `env_id` (None for an env
    built without `gym.make`) and `kwargs` (every construction argument, defaults included,
    without `render_mode`) say which envs it fits."""

    data: bytes = field(repr=False)
    env_class: str = field(init=False)
    env_id: str | None = field(init=False)
    kwargs: dict[str, Any] = field(init=False)
    format_version: int = field(init=False)
    package_version: str = field(init=False)
    kwargs_hash: str = field(init=False)

    def __post_init__(self) -> None:
        meta, arrays = unpack(self.data, "snapshot")
        header = {
            "kind": str,
            "format_version": int,
            "package_version": str,
            "env_class": str,
            "env_id": (str, type(None)),
            "kwargs": dict,
            "kwargs_hash": str,
            "fields": dict,
        }
        for key, kind in header.items():
            if not isinstance(meta.get(key), kind):
                raise StateFormatError(f"snapshot: its header has no valid {key!r}")
        extra = sorted(set(meta) - set(header) - {"format"})
        if extra:
            raise StateFormatError(f"snapshot: unexpected header field(s) {extra}")
        if meta["kind"] != "env":
            raise StateFormatError(f"snapshot: holds a {meta['kind']!r} state, not an env's")
        if meta["format_version"] != FORMAT_VERSION:
            raise StateFormatError(
                f"snapshot: format version {meta['format_version']}; this fluids-bench reads "
                f"version {FORMAT_VERSION}"
            )
        kwargs = Decoder(arrays, {}).decode(meta["kwargs"], "snapshot kwargs")
        if not isinstance(kwargs, dict) or kwargs_hash(kwargs) != meta["kwargs_hash"]:
            raise StateFormatError("snapshot: its kwargs do not match its kwargs hash (damaged)")
        for key in ("env_class", "env_id", "format_version", "package_version", "kwargs_hash"):
            object.__setattr__(self, key, meta[key])
        object.__setattr__(self, "kwargs", kwargs)
        object.__setattr__(self, "_fields", meta["fields"])

    @classmethod
    def from_bytes(cls, data: bytes) -> EnvSnapshot:
        """Read stored snapshot bytes (checked; never unpickled)."""
        return cls(bytes(data) if isinstance(data, bytearray | memoryview) else data)

    @classmethod
    def _from_parts(cls, data: bytes, meta: dict, arrays: list, kwargs: dict) -> EnvSnapshot:
        """The snapshot `snapshot()` just packed (without reading it back)."""
        self = object.__new__(cls)
        values = {key: meta[key] for key in ("env_class", "env_id", "format_version")}
        values.update(package_version=meta["package_version"], kwargs_hash=meta["kwargs_hash"])
        values.update(data=data, kwargs=kwargs, _fields=meta["fields"])
        for key, value in values.items():
            object.__setattr__(self, key, value)
        return self

    def to_bytes(self) -> bytes:
        """The snapshot as bytes (an `.npz` archive; write it to a file as it is)."""
        return self.data

    def __reduce__(self):
        return (EnvSnapshot, (self.data,))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, EnvSnapshot) and other.data == self.data

    def __hash__(self) -> int:
        return hash(self.data)


class SnapshotMixin:
    """`snapshot()` / `restore()` for an env class; see the module docstring."""

    # attribute names holding the env's state (Gymnasium's np_random is always added)
    _snapshot_fields: tuple[str, ...] = ()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "__init__" in cls.__dict__:
            cls.__init__ = _recording_kwargs(cls.__dict__["__init__"])

    # -- what each env declares ------------------------------------------------------------
    def _snapshot_static(self) -> dict[str, Any]:
        """Objects reachable from the state that depend on the kwargs alone (name -> object):
        stored by name and taken from the restoring env."""
        return {}

    def _snapshot_state(self) -> dict[str, Any]:
        """The env's state as a dict of fields (an attribute not set yet is `ABSENT`)."""
        names = (*RNG_FIELDS, *self._snapshot_fields)
        return {name: getattr(self, name, ABSENT) for name in names}

    def _restore_state(self, state: dict[str, Any]) -> None:
        """Put `state` (what `_snapshot_state` returned, decoded) into this env."""
        for name, value in state.items():
            if value is ABSENT:
                self.__dict__.pop(name, None)
            else:
                setattr(self, name, value)

    def _snapshot_reference_step(self, rng: np.random.Generator) -> bool:
        """Take one step with a sampled action (for the field checks' reference states);
        False when the episode ended."""
        space = self.action_space
        if callable(space):  # a PettingZoo env: one space per agent
            agents = list(self.agents)
            if not agents:
                return False
            actions = {}
            for agent in agents:
                agent_space = space(agent)
                agent_space.seed(int(rng.integers(2**31)))
                actions[agent] = agent_space.sample()
            self.step(actions)
            return bool(self.agents)
        space.seed(int(rng.integers(2**31)))
        _, _, terminated, truncated, _ = self.step(space.sample())
        return not (terminated or truncated)

    # -- the API ---------------------------------------------------------------------------
    def snapshot(self) -> EnvSnapshot:
        """The env's current state in the safe state format; `restore` it on an env of
        the same id and kwargs to continue from here bit-identically."""
        static = {id(obj): name for name, obj in self._snapshot_static().items()}
        encoder = Encoder(static)
        kwargs = self._snapshot_kwargs()
        kwargs_tree = encoder.encode(kwargs, "kwargs")
        fields = encoder.encode(self._snapshot_state(), "state")
        meta = {
            "kind": "env",
            "format_version": FORMAT_VERSION,
            "package_version": package_version(),
            "env_class": class_name(type(self)),
            "env_id": self._snapshot_env_id(),
            "kwargs": kwargs_tree,
            "kwargs_hash": kwargs_hash(kwargs),
            "fields": fields,
        }
        return EnvSnapshot._from_parts(pack(meta, encoder.arrays), meta, encoder.arrays, kwargs)

    def restore(self, snapshot: EnvSnapshot | bytes) -> None:
        """Continue from `snapshot` (taken from an env of the same class, id and kwargs;
        stored bytes are read with `EnvSnapshot.from_bytes`).

        Raises `TypeError` when `snapshot` is neither, and `ValueError` (a `StateFormatError`)
        naming the difference or the damage when it does not fit this env. This env is left
        as it was when the snapshot is refused."""
        where = f"{type(self).__name__}.restore"
        if isinstance(snapshot, bytes | bytearray | memoryview):
            snapshot = EnvSnapshot.from_bytes(snapshot)
        if not isinstance(snapshot, EnvSnapshot):
            raise TypeError(
                f"{where}: snapshot is {type(snapshot).__name__}; "
                "allowed: an EnvSnapshot from env.unwrapped.snapshot() or its bytes"
            )
        if snapshot.package_version != package_version():
            raise StateFormatError(
                f"{where}: the snapshot was written by fluids-bench "
                f"{snapshot.package_version}, this is {package_version()}; restore it with "
                "that version"
            )
        mine = class_name(type(self))
        if snapshot.env_class != mine:
            raise StateFormatError(
                f"{where}: the snapshot is of {snapshot.env_class}, this env is {mine}"
            )
        env_id = self._snapshot_env_id()
        if snapshot.env_id is not None and env_id is not None and snapshot.env_id != env_id:
            raise StateFormatError(
                f"{where}: the snapshot is of id {snapshot.env_id!r}, this env is {env_id!r}"
            )
        kwargs = self._snapshot_kwargs()
        if snapshot.kwargs != kwargs:
            diff = sorted(
                k
                for k in set(kwargs) | set(snapshot.kwargs)
                if kwargs.get(k, "<missing>") != snapshot.kwargs.get(k, "<missing>")
            )
            shown = ", ".join(
                f"{k}: snapshot {snapshot.kwargs.get(k, '<missing>')!r}, "
                f"env {kwargs.get(k, '<missing>')!r}"
                for k in diff
            )
            raise StateFormatError(
                f"{where}: the snapshot's env was built with other kwargs ({shown}); "
                "restore into an env built like it"
            )
        names, schema = self._snapshot_schema()
        # the arrays are read afresh from the bytes at every restore: envs restored from one
        # snapshot never share an array, nor with the env the snapshot was taken from
        _, arrays = unpack(snapshot.data, "snapshot")
        decoder = Decoder(arrays, self._snapshot_static(), schema)
        try:
            state = decoder.decode(snapshot._fields, "state")
            if type(state) is not dict:
                raise StateFormatError("state: the fields are not a dict")
            missing = sorted(names - set(state), key=str)
            extra = sorted(set(state) - names, key=str)
            if missing or extra:
                raise StateFormatError(
                    f"state: {f'missing field(s) {missing}' if missing else ''}"
                    f"{'; ' if missing and extra else ''}"
                    f"{f'unexpected field(s) {extra}' if extra else ''}"
                )
            unused = len(arrays) - len(decoder.used)
            if unused:
                raise StateFormatError(f"state: {unused} stored array(s) belong to no field")
        except StateFormatError as error:
            raise StateFormatError(f"{where}: {error}") from None
        self._restore_state(state)

    # -- helpers ---------------------------------------------------------------------------
    def _snapshot_env_id(self) -> str | None:
        spec = getattr(self, "spec", None)
        return None if spec is None else spec.id

    def _snapshot_kwargs(self) -> dict[str, Any]:
        kwargs = getattr(self, "_construction_kwargs", None)
        if kwargs is None:
            raise RuntimeError(f"{type(self).__name__}: construction kwargs were not recorded")
        return {k: v for k, v in kwargs.items() if k not in IGNORED_KWARGS}

    def _snapshot_schema(self) -> tuple[frozenset, Schema]:
        """The top-level field names and the field checks for this class and kwargs, learnt
        once per process from a fresh env (after reset and a few sampled steps)."""
        kwargs = self._snapshot_kwargs()
        key = (class_name(type(self)), json.dumps(kwargs, sort_keys=True, default=repr))
        if key not in _SCHEMAS:
            reference = type(self)(**kwargs)
            schema, names = Schema(), None
            rng = np.random.default_rng(0)
            try:
                reference.reset(seed=0)
                for step in range(REFERENCE_STEPS + 1):
                    state = reference._snapshot_state()
                    skip = {id(obj) for obj in reference._snapshot_static().values()}
                    names = set(state) if names is None else names | set(state)
                    schema.learn(state, skip)
                    if step < REFERENCE_STEPS and not reference._snapshot_reference_step(rng):
                        break
            finally:
                reference.close()
            _SCHEMAS[key] = (frozenset(names), schema)
        return _SCHEMAS[key]


def _recording_kwargs(init):
    """Wrap `__init__` so the instance records its construction kwargs (defaults applied,
    as plain Python values) before anything else runs: the outermost `__init__` wins."""
    signature = inspect.signature(init)

    @functools.wraps(init)
    def recording(self, *args: Any, **kwargs: Any) -> None:
        if "_construction_kwargs" not in self.__dict__:
            try:
                bound = signature.bind(self, *args, **kwargs)
            except TypeError:
                pass  # let __init__ raise its own error
            else:
                bound.apply_defaults()
                arguments = dict(bound.arguments)
                arguments.pop(next(iter(signature.parameters)))  # self
                self._construction_kwargs = _plain(arguments)
        init(self, *args, **kwargs)

    return recording


# -- wrapped envs -------------------------------------------------------------------------


@dataclass(frozen=True)
class WrappedSnapshot:
    """A snapshot of a wrapped env: the base env's `EnvSnapshot` and the wrappers' episode
    counters (outermost first). `to_bytes()` / `from_bytes()` store it in the safe format."""

    env: EnvSnapshot
    wrappers: tuple[tuple[str, dict[str, Any]], ...]

    def to_bytes(self) -> bytes:
        """The snapshot as bytes (an `.npz` archive: the wrappers' counters as JSON and the
        env's snapshot as one uint8 array)."""
        meta = {
            "kind": "wrapped",
            "format_version": FORMAT_VERSION,
            "wrappers": [[name, dict(values)] for name, values in self.wrappers],
        }
        return pack(meta, [np.frombuffer(self.env.to_bytes(), dtype=np.uint8)])

    @classmethod
    def from_bytes(cls, data: bytes, what: str = "snapshot") -> WrappedSnapshot:
        """Read what `to_bytes` wrote (checked field by field; never unpickled)."""
        meta, arrays = unpack(data, what)
        if meta.get("kind") != "wrapped" or set(meta) != {
            "format",
            "kind",
            "format_version",
            "wrappers",
        }:
            raise StateFormatError(f"{what}: not a wrapped env snapshot (header {sorted(meta)})")
        if meta["format_version"] != FORMAT_VERSION:
            raise StateFormatError(
                f"{what}: format version {meta['format_version']}; this fluids-bench reads "
                f"version {FORMAT_VERSION}"
            )
        if len(arrays) != 1 or arrays[0].dtype != np.uint8 or arrays[0].ndim != 1:
            raise StateFormatError(f"{what}: expected one uint8 entry holding the env's snapshot")
        wrappers = []
        for item in meta["wrappers"] if type(meta["wrappers"]) is list else [None]:
            if type(item) is not list or len(item) != 2 or type(item[1]) is not dict:
                raise StateFormatError(f"{what}: bad wrapper entry {item!r}")
            wrappers.append((item[0], _check_wrapper(item[0], item[1], what)))
        return cls(EnvSnapshot.from_bytes(arrays[0].tobytes()), tuple(wrappers))


def from_legacy(env: gym.Env, old: Any) -> WrappedSnapshot:
    """Convert a pickled state of an older fluids-bench (a `WrappedSnapshot` whose env part
    holds a pickled `state`), already unpickled by a caller who trusts it, into this format:
    it is put into `env` (built like the one it came from, and reset) and snapshotted again."""
    import io
    import pickle

    base = getattr(old, "env", None)
    legacy = getattr(base, "__dict__", {})
    if not isinstance(old, WrappedSnapshot) or not isinstance(legacy.get("state"), bytes):
        raise ValueError(
            f"a legacy stored state must be a WrappedSnapshot of a pickled env state, got "
            f"{type(old).__name__}"
        )
    unwrapped = env.unwrapped
    mine = (class_name(type(unwrapped)), unwrapped._snapshot_kwargs())
    if (legacy.get("env_class"), legacy.get("kwargs")) != mine:
        raise ValueError(
            f"a legacy stored state of {legacy.get('env_class')} with kwargs "
            f"{legacy.get('kwargs')}; this env is {mine[0]} with {mine[1]}"
        )
    static = unwrapped._snapshot_static()
    unpickler = pickle.Unpickler(io.BytesIO(legacy["state"]))
    unpickler.persistent_load = static.__getitem__
    unwrapped._restore_state(unpickler.load())
    for wrapper, (name, values) in zip(_chain(env), old.wrappers, strict=False):
        if type(wrapper).__name__ == name:
            for key, value in _check_wrapper(name, dict(values), "legacy state").items():
                setattr(wrapper, key, value)
    return snapshot(env)


def _check_wrapper(name: Any, values: dict, where: str) -> dict[str, Any]:
    """`values` if they are the counters of wrapper `name` (ints, bools or None)."""
    if name not in WRAPPER_FIELDS:
        raise StateFormatError(
            f"{where}: unknown wrapper {name!r} (allowed: {sorted(WRAPPER_FIELDS)})"
        )
    if set(values) != set(WRAPPER_FIELDS[name]):
        raise StateFormatError(
            f"{where}: wrapper {name} has fields {sorted(values)}; expected "
            f"{sorted(WRAPPER_FIELDS[name])}"
        )
    for key, value in values.items():
        if value is not None and type(value) not in (int, bool):
            raise StateFormatError(f"{where}: wrapper {name}.{key} is {value!r}, not a count")
    return values


def _chain(env: gym.Env) -> list[gym.Env]:
    out = []
    while isinstance(env, gym.Wrapper):
        out.append(env)
        env = env.env
    return out


def snapshot(env: gym.Env) -> WrappedSnapshot:
    """`env.unwrapped.snapshot()` plus the wrappers' counters (`TimeLimit`'s elapsed steps,
    `OrderEnforcing`'s reset flag): restore it with [`restore`][fluids_bench.core.snapshot.restore]
    into an env built the same way (`gym.make` of the same id) and it also truncates at the
    same step."""
    wrappers = tuple(
        (type(w).__name__, {k: getattr(w, k) for k in WRAPPER_FIELDS.get(type(w).__name__, ())})
        for w in _chain(env)
    )
    return WrappedSnapshot(env.unwrapped.snapshot(), wrappers)


def restore(env: gym.Env, snap: WrappedSnapshot | bytes) -> None:
    """Put `snap` (from [`snapshot`][fluids_bench.core.snapshot.snapshot], or its bytes) into
    `env`, which must be wrapped the same way. A restored env that was never reset steps
    on as if it had been (the wrappers' flags come from the snapshot)."""
    if isinstance(snap, bytes | bytearray | memoryview):
        snap = WrappedSnapshot.from_bytes(bytes(snap))
    if not isinstance(snap, WrappedSnapshot):
        raise TypeError(
            f"restore: snap is {type(snap).__name__}; allowed: a WrappedSnapshot from "
            "fluids_bench.core.snapshot.snapshot(env) or its bytes"
        )
    chain = _chain(env)
    names = tuple(type(w).__name__ for w in chain)
    if names != tuple(name for name, _ in snap.wrappers):
        raise StateFormatError(
            f"restore: the snapshot's env was wrapped in {[n for n, _ in snap.wrappers]}, "
            f"this one in {list(names)}"
        )
    for name, values in snap.wrappers:
        _check_wrapper(name, values, "restore")
    env.unwrapped.restore(snap.env)
    for wrapper, (_, values) in zip(chain, snap.wrappers, strict=True):
        for key, value in values.items():
            setattr(wrapper, key, value)
        if (
            isinstance(wrapper, gym.wrappers.PassiveEnvChecker)
            and not wrapper.checked_step
            and wrapper._previous_data is None
        ):
            # never reset: Gymnasium's checker compares the first step's data with the reset's
            # (and fails on None); it has no reset data to compare, so nothing is shared
            wrapper._previous_data = (None, {})
