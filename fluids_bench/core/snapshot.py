"""Snapshots of an env's state: `env.unwrapped.snapshot()` and `restore(snapshot)`.

Every Gymnasium env of the suite mixes in `SnapshotMixin`. `snapshot()` returns an
`EnvSnapshot`: a picklable record of everything the env's future depends on (the
simulator, the supervisor's memory where it has one, the episode counters and `np_random`),
plus the env's class, id and construction kwargs. `restore(snapshot)` on another env of the
same class and kwargs (built with `gym.make` of the same id, reset with any seed or not reset
at all) makes it continue bit-identically under the same actions: the same observations,
rewards, terminated/truncated flags, infos and supervisor labels. Restoring into an env of
another class, id or kwargs raises `ValueError` (`render_mode` may differ: drawing only
reads).

What an env's state is, each env says in `SnapshotMixin._snapshot_fields` (attribute
names, copied by pickling them together, so objects they share stay shared) and
`SnapshotMixin._snapshot_static` (objects built from the kwargs alone, which reset and
step never change, such as a compiled FLUIDS layout: stored by name, never copied, and taken
from the restoring env). An env whose state needs more (MuJoCo's `MjData`) overrides
`SnapshotMixin._snapshot_state` / `SnapshotMixin._restore_state`.

`env.unwrapped.snapshot()` covers the env, not the wrappers `gym.make` puts around it:
`TimeLimit` counts the episode's steps itself. `snapshot` and `restore` take a
wrapped env and also carry the wrappers' counters (`TimeLimit`'s elapsed steps, the
`OrderEnforcing` reset flag), so truncation happens at the same step too.
"""

from __future__ import annotations

import functools
import inspect
import io
import pickle
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

# Gymnasium's own per-env randomness (set by Env.reset(seed=...)): part of every snapshot
RNG_FIELDS = ("_np_random", "_np_random_seed")
# construction kwargs that do not change what the env computes
IGNORED_KWARGS = ("render_mode",)
# wrapper attributes that are episode state (wrapper class name -> attribute names)
WRAPPER_FIELDS = {
    "TimeLimit": ("_elapsed_steps",),
    "OrderEnforcing": ("_has_reset",),
}


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


def _class_name(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


@dataclass(frozen=True)
class EnvSnapshot:
    """The state of one env at one moment (picklable; restore it with `env.restore`).

    `env_class` (`module:qualname`), `env_id` (None for an env built without
    `gym.make`) and `kwargs` (every construction argument, defaults included, without
    `render_mode`) say which envs it fits; `state` is the pickled state itself."""

    env_class: str
    env_id: str | None
    kwargs: dict[str, Any]
    state: bytes = field(repr=False)


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
        """The env's state as a dict (pickled by `snapshot`)."""
        names = (*RNG_FIELDS, *self._snapshot_fields)
        return {name: getattr(self, name) for name in names if hasattr(self, name)}

    def _restore_state(self, state: dict[str, Any]) -> None:
        """Put `state` (what `_snapshot_state` returned, unpickled) into this env."""
        for name, value in state.items():
            setattr(self, name, value)

    # -- the API ---------------------------------------------------------------------------
    def snapshot(self) -> EnvSnapshot:
        """A picklable copy of the env's current state; `restore` it on an env of the
        same id and kwargs to continue from here bit-identically."""
        static = self._snapshot_static()
        by_id = {id(obj): name for name, obj in static.items()}
        buffer = io.BytesIO()
        pickler = pickle.Pickler(buffer, protocol=pickle.HIGHEST_PROTOCOL)
        pickler.persistent_id = lambda obj: by_id.get(id(obj))
        pickler.dump(self._snapshot_state())
        return EnvSnapshot(
            env_class=_class_name(type(self)),
            env_id=self._snapshot_env_id(),
            kwargs=self._snapshot_kwargs(),
            state=buffer.getvalue(),
        )

    def restore(self, snapshot: EnvSnapshot) -> None:
        """Continue from `snapshot` (taken from an env of the same class, id and kwargs).

        Raises `ValueError` naming the difference when `snapshot` is from another kind
        of env, and `TypeError` when it is not an `EnvSnapshot`."""
        if not isinstance(snapshot, EnvSnapshot):
            raise TypeError(
                f"{type(self).__name__}.restore: snapshot is {type(snapshot).__name__}; "
                "allowed: an EnvSnapshot from env.unwrapped.snapshot()"
            )
        mine = _class_name(type(self))
        if snapshot.env_class != mine:
            raise ValueError(
                f"{type(self).__name__}.restore: the snapshot is of {snapshot.env_class}, "
                f"this env is {mine}"
            )
        env_id = self._snapshot_env_id()
        if snapshot.env_id is not None and env_id is not None and snapshot.env_id != env_id:
            raise ValueError(
                f"{type(self).__name__}.restore: the snapshot is of id {snapshot.env_id!r}, "
                f"this env is {env_id!r}"
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
            raise ValueError(
                f"{type(self).__name__}.restore: the snapshot's env was built with other "
                f"kwargs ({shown}); restore into an env built like it"
            )
        static = self._snapshot_static()

        def load(name: str) -> Any:
            if name not in static:
                raise ValueError(
                    f"{type(self).__name__}.restore: the snapshot refers to {name!r}, which "
                    f"this env does not have (allowed: {sorted(static)})"
                )
            return static[name]

        unpickler = pickle.Unpickler(io.BytesIO(snapshot.state))
        unpickler.persistent_load = load
        self._restore_state(unpickler.load())

    # -- helpers ---------------------------------------------------------------------------
    def _snapshot_env_id(self) -> str | None:
        spec = getattr(self, "spec", None)
        return None if spec is None else spec.id

    def _snapshot_kwargs(self) -> dict[str, Any]:
        kwargs = getattr(self, "_construction_kwargs", None)
        if kwargs is None:
            raise RuntimeError(f"{type(self).__name__}: construction kwargs were not recorded")
        return {k: v for k, v in kwargs.items() if k not in IGNORED_KWARGS}


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
    """A snapshot of a wrapped env: the base env's `EnvSnapshot` and the wrappers'
    episode counters (outermost first)."""

    env: EnvSnapshot
    wrappers: tuple[tuple[str, dict[str, Any]], ...]


def _chain(env: gym.Env) -> list[gym.Env]:
    out = []
    while isinstance(env, gym.Wrapper):
        out.append(env)
        env = env.env
    return out


def snapshot(env: gym.Env) -> WrappedSnapshot:
    """`env.unwrapped.snapshot()` plus the wrappers' counters (`TimeLimit`'s elapsed steps,
    `OrderEnforcing`'s reset flag): restore it with `restore` into an env built the
    same way (`gym.make` of the same id) and it also truncates at the same step."""
    wrappers = tuple(
        (type(w).__name__, {k: getattr(w, k) for k in WRAPPER_FIELDS.get(type(w).__name__, ())})
        for w in _chain(env)
    )
    return WrappedSnapshot(env.unwrapped.snapshot(), wrappers)


def restore(env: gym.Env, snap: WrappedSnapshot) -> None:
    """Put `snap` (from `snapshot`) into `env`, which must be wrapped the same way."""
    chain = _chain(env)
    names = tuple(type(w).__name__ for w in chain)
    if names != tuple(name for name, _ in snap.wrappers):
        raise ValueError(
            f"restore: the snapshot's env was wrapped in {[n for n, _ in snap.wrappers]}, "
            f"this one in {list(names)}"
        )
    env.unwrapped.restore(snap.env)
    for wrapper, (_, values) in zip(chain, snap.wrappers, strict=True):
        for key, value in values.items():
            setattr(wrapper, key, value)
