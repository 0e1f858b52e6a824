"""Read the entries of a Google-style docstring section (`Args:`, `Attributes:`).

The docs' argument tables and `FluidsConfig`'s field descriptions come from the code's
docstrings through this one reader, so the text that mkdocstrings renders and the text the
tables show are the same.
"""

from __future__ import annotations

import inspect
import re

_ENTRY = re.compile(r"^(\*{0,2}[A-Za-z_]\w*)\s*(?:\([^)]*\))?\s*:(?:\s+(.*))?$")


def section_entries(doc: str | None, section: str) -> dict[str, str]:
    """The entries of `section` (e.g. `"Args"`) in the Google-style docstring `doc`: each
    name (`name:` or `name (type):`) mapped to its description, continuation lines joined by
    single spaces. Empty when `doc` has no such section."""
    lines = inspect.cleandoc(doc or "").splitlines()
    header = f"{section}:"
    try:
        start = next(i for i, line in enumerate(lines) if line.strip() == header)
    except StopIteration:
        return {}
    base = _indent(lines[start])
    entries: dict[str, list[str]] = {}
    entry_indent, name = None, None
    for line in lines[start + 1 :]:
        if not line.strip():
            continue
        indent = _indent(line)
        if indent <= base:
            break  # the section ended
        if entry_indent is None:
            entry_indent = indent
        match = _ENTRY.match(line.strip()) if indent == entry_indent else None
        if match:
            name = match.group(1)
            entries[name] = [match.group(2) or ""]
        elif name is not None and indent > entry_indent:
            entries[name].append(line.strip())
        else:
            raise ValueError(f"{section}: cannot read the line {line.strip()!r}")
    return {k: " ".join(p for p in parts if p) for k, parts in entries.items()}


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())
