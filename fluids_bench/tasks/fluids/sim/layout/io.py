"""The layout file format: a `LayoutSpec` as JSON (read and written) or TOML (read only).

A file is one object with `"format_version": 1` and the fields of `LayoutSpec`; each
element (lane, sidewalk, crosswalk, light, route, walk) is an object with its dataclass's fields,
points are `[x, y]` pairs in metres, light phases `[state, seconds]` pairs. Fields with a
default may be left out (TOML has no `null`: leave out a `light` that is absent). Every error
is a `ValueError` naming the element and the field at fault, for example
`lanes[2] ('north_in_0'): field 'width' is -1; allowed: a finite number > 0`.

Limits (see `fluids_bench.tasks.fluids.sim.layout.spec`): `bounds` within ±1 km of the
origin, every point (lights included) within `bounds` grown by 1 km; lanes must not cross
themselves or overlap each other, and no route may exit by a lane some route enters by; areas and
islands are simple polygons; `curb_radius` is at most 50 m and a quarter of the smaller side of
`bounds`; a light holds each state 0.1 s to 1 h, and its offset lies within one loop. An island
across a car route is refused when the layout is compiled.

`save_layout(spec, path)` then `load_layout(path)` gives back an equal spec.
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import secrets
import tomllib
from pathlib import Path
from typing import Any

from fluids_bench.tasks.fluids.sim.layout.spec import (
    CarRoute,
    Crosswalk,
    Lane,
    LayoutSpec,
    Light,
    Sidewalk,
    Walk,
)

FORMAT_VERSION = 1
_INT_LIMIT = 2**1023  # larger ints overflow float()

# the element lists of a layout: key -> (class, what LayoutSpec.__post_init__ calls one in errors)
ELEMENTS: dict[str, tuple[type, str]] = {
    "lanes": (Lane, "lane"),
    "sidewalks": (Sidewalk, "sidewalk"),
    "crosswalks": (Crosswalk, "crosswalk"),
    "lights": (Light, "light"),
    "routes": (CarRoute, "route"),
    "walks": (Walk, "walk"),
}

# the JSON shape of every field that is not a plain number; fields not listed are numbers
_SHAPES: dict[str, str] = {
    "name": "str",
    "kind": "str",
    "entry": "str",
    "exit": "str",
    "light": "str?",
    "centerline": "points",
    "waypoints": "points",
    "via": "points",
    "start": "point",
    "end": "point",
    "position": "point",
    "phases": "phases",
    "bounds": "bounds",
    "areas": "polygons",
    "islands": "polygons",
}
_ALLOWED_SHAPE = {
    "str": "a string",
    "str?": "a string or null",
    "number": "a number",
    "point": "an [x, y] pair of numbers",
    "points": "a list of [x, y] pairs of numbers",
    "phases": "a list of [state, seconds] pairs",
    "bounds": "[xmin, ymin, xmax, ymax] numbers",
    "polygons": "a list of polygons, each a list of [x, y] pairs of numbers",
}


def _short(value: Any, limit: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _is_number(v: Any) -> bool:
    # bools are ints to Python, but not numbers in a layout; huge ints do not fit a float
    return isinstance(v, float) or (
        isinstance(v, int) and not isinstance(v, bool) and abs(v) < _INT_LIMIT
    )


def _is_point(v: Any) -> bool:
    return isinstance(v, list | tuple) and len(v) == 2 and all(_is_number(c) for c in v)


def _is_points(v: Any) -> bool:
    return isinstance(v, list | tuple) and all(_is_point(p) for p in v)


def _has_shape(value: Any, shape: str) -> bool:
    if shape == "str":
        return isinstance(value, str)
    if shape == "str?":
        return value is None or isinstance(value, str)
    if shape == "number":
        return _is_number(value)
    if shape == "point":
        return _is_point(value)
    if shape == "points":
        return _is_points(value)
    if shape == "phases":
        return isinstance(value, list | tuple) and all(
            isinstance(p, list | tuple)
            and len(p) == 2
            and isinstance(p[0], str)
            and _is_number(p[1])
            for p in value
        )
    if shape == "bounds":
        return isinstance(value, list | tuple) and len(value) == 4 and all(map(_is_number, value))
    if shape == "polygons":
        return isinstance(value, list | tuple) and all(_is_points(p) for p in value)
    raise AssertionError(shape)


def _convert(value: Any, shape: str) -> Any:
    """A checked JSON value as the spec stores it: lists become tuples, numbers floats."""
    if shape == "point":
        return (float(value[0]), float(value[1]))
    if shape == "points":
        return tuple(_convert(p, "point") for p in value)
    if shape == "phases":
        return tuple((state, float(seconds)) for state, seconds in value)
    if shape == "bounds":
        return tuple(float(v) for v in value)
    if shape == "polygons":
        return tuple(_convert(p, "points") for p in value)
    return value


def _element_name(key: str, d: Any) -> str | None:
    """The name the spec gives an element (a route's is `entry->exit`), if `d` has one."""
    if not isinstance(d, dict):
        return None
    if key == "routes":
        entry, exit_ = d.get("entry"), d.get("exit")
        return f"{entry}->{exit_}" if isinstance(entry, str) and isinstance(exit_, str) else None
    return d["name"] if isinstance(d.get("name"), str) else None


def _fields(cls: type, d: Any, where: str, skip: tuple[str, ...] = ()) -> dict[str, Any]:
    """Check `d` against the fields of dataclass `cls`; return the converted keyword args."""
    if not isinstance(d, dict):
        raise ValueError(
            f"{where}: is {_short(d)}; allowed: an object with fields of {cls.__name__}"
        )
    fields = {f.name: f for f in dataclasses.fields(cls)}
    allowed = sorted(set(fields) | set(skip))
    for key in d:
        if key not in allowed:
            raise ValueError(f"{where}: unknown field {key!r}; allowed: {', '.join(allowed)}")
    kwargs = {}
    for name, f in fields.items():
        required = f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        if name not in d:
            if required:
                raise ValueError(f"{where}: missing required field {name!r}")
            continue
        if name in ELEMENTS:
            kwargs[name] = d[name]  # element lists are checked element by element
            continue
        shape = _SHAPES.get(name, "number")
        if not _has_shape(d[name], shape):
            raise ValueError(
                f"{where}: field {name!r} is {_short(d[name])}; allowed: {_ALLOWED_SHAPE[shape]}"
            )
        kwargs[name] = _convert(d[name], shape)
    return kwargs


def _relabel(err: ValueError, labels: dict[str, str]) -> ValueError:
    """Rewrite the spec's `lane 'x': ...` prefix of `err` into the file's `lanes[2] ('x')`."""
    msg = str(err)
    for spec_where, label in labels.items():
        if msg.startswith(spec_where + ": "):
            return ValueError(label + msg[len(spec_where) :])
    return err


def layout_from_dict(d: Any) -> LayoutSpec:
    """Build and validate a `LayoutSpec` from the parsed contents of a layout file."""
    if not isinstance(d, dict):
        raise ValueError(f"layout: is {_short(d)}; allowed: an object with 'format_version': 1")
    where = f"layout '{d['name']}'" if isinstance(d.get("name"), str) else "layout"
    if "format_version" not in d:
        raise ValueError(f"{where}: missing required field 'format_version'")
    version = d["format_version"]
    if not _is_number(version) or version != FORMAT_VERSION:
        raise ValueError(
            f"{where}: field 'format_version' is {_short(version)}; allowed: {FORMAT_VERSION}"
        )
    kwargs = _fields(LayoutSpec, d, where, skip=("format_version",))
    labels: dict[str, str] = {}  # the spec's name for an element -> its label in the file
    for key, (cls, spec_kind) in ELEMENTS.items():
        items = kwargs.get(key, [])
        if not isinstance(items, list | tuple):
            raise ValueError(
                f"{where}: field {key!r} is {_short(items)}; allowed: a list of objects"
            )
        built = []
        for i, item in enumerate(items):
            name = _element_name(key, item)
            label = f"{key}[{i}]" + (f" ({name!r})" if name is not None else "")
            elem_kwargs = _fields(cls, item, label)  # a name is there and a string past here
            spec_where = f"{spec_kind} '{name}'"  # how LayoutSpec's checks name the element
            try:
                built.append(cls(**elem_kwargs))
            except ValueError as err:
                raise _relabel(err, {spec_where: label}) from None
            labels.setdefault(spec_where, label)
        if key in kwargs:
            kwargs[key] = tuple(built)
    try:
        return LayoutSpec(**kwargs)
    except ValueError as err:
        raise _relabel(err, labels) from None


def _plain(value: Any) -> Any:
    """Tuples as lists, recursively (what JSON writes)."""
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    return value


def layout_to_dict(spec: LayoutSpec) -> dict[str, Any]:
    """The file contents for `spec`: `format_version` first, then every field, in order."""
    out: dict[str, Any] = {"format_version": FORMAT_VERSION}
    for f in dataclasses.fields(spec):
        value = getattr(spec, f.name)
        if f.name in ELEMENTS:
            out[f.name] = [
                {g.name: _plain(getattr(e, g.name)) for g in dataclasses.fields(e)} for e in value
            ]
        else:
            out[f.name] = _plain(value)
    return out


# a list of scalars as json.dumps(indent=...) writes it, one per line (no raw newline can stand in
# a JSON string, so this never matches inside one): written on one line, e.g. a point [x, y]
_FLAT_LIST = re.compile(r"\[\n\s*([^\[\]{}\n]+(?:\n\s*[^\[\]{}\n]+)*)\n\s*\]")


def save_layout(spec: LayoutSpec, path: str | os.PathLike) -> None:
    """Write `spec` to `path` as JSON, atomically (a temporary file, then a rename)."""
    path = Path(path)
    text = json.dumps(layout_to_dict(spec), indent=2, allow_nan=False)
    text = _FLAT_LIST.sub(lambda m: "[" + " ".join(map(str.strip, m[1].split("\n"))) + "]", text)
    # a fresh name in the same folder (so the rename is atomic), created with the umask's mode
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text + "\n")
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _no_duplicate_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object whose keys are unique (`json` would keep the last of two silently)."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise ValueError(f"key {key!r} appears twice in one object; allowed: each key once")
        out[key] = value
    return out


def load_layout(path: str | os.PathLike) -> LayoutSpec:
    """Read a layout file (`.toml`: TOML, anything else: JSON); errors name the file."""
    path = Path(path)
    try:
        if path.suffix.lower() == ".toml":
            with open(path, "rb") as fh:
                data = tomllib.load(fh)
        else:
            with open(path, encoding="utf-8") as fh:
                data = json.load(fh, object_pairs_hook=_no_duplicate_keys)
    except RecursionError:
        raise ValueError(f"{path}: nested too deeply to be a layout file") from None
    except json.JSONDecodeError as err:
        raise ValueError(
            f"{path}: invalid JSON at line {err.lineno}, column {err.colno}: {err.msg}"
        ) from None
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"{path}: invalid TOML: {err}") from None
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not UTF-8 text: {err}") from None
    except ValueError as err:  # a duplicate key
        raise ValueError(f"{path}: {err}") from None
    try:
        return layout_from_dict(data)
    except ValueError as err:
        raise ValueError(f"{path}: {err}") from None
    except RecursionError:
        raise ValueError(f"{path}: nested too deeply to be a layout file") from None


__all__ = ["FORMAT_VERSION", "layout_from_dict", "layout_to_dict", "load_layout", "save_layout"]
