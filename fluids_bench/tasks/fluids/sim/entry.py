"""A number stored as one entry of an array attribute: what lets a batch keep it in a row.

A batch of worlds (`fluids_bench.tasks.fluids.sim.batch`) stores each world's arrays as
rows of its own arrays, so that one operation updates every world. A scalar such as a world's
clock joins them as a 0-d array (or an entry of a small one); `Entry` reads and writes it
as the plain number the rest of the code expects.
"""

from __future__ import annotations

from typing import Any


class Entry:
    """Attribute descriptor for `kind(getattr(obj, array)[index])`, written in place."""

    def __init__(self, array: str, index: Any, kind: type) -> None:
        self.array, self.index, self.kind = array, index, kind

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:
            return self
        return self.kind(getattr(obj, self.array)[self.index])

    def __set__(self, obj: Any, value: Any) -> None:
        getattr(obj, self.array)[self.index] = value
