"""Append-only JSON-lines logs, the resume files of long runs (one finished unit a line).

A run killed mid-write leaves at most a torn last line; reading skips it, so that unit is
simply done again.
"""

from __future__ import annotations

import json
import os
from typing import Any


def read_rows(path: str | os.PathLike | None) -> list[dict[str, Any]]:
    """The complete rows of the log at `path` (none if it is None or does not exist)."""
    if path is None or not os.path.exists(path):
        return []
    rows = []
    with open(path, encoding="utf-8") as f:
        for line in f:
            try:
                rows.append(json.loads(line))
            except json.JSONDecodeError:
                continue  # a torn line: that unit is redone
    return rows
