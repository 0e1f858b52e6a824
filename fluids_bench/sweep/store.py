"""The result store of a sweep: one CSV row per finished configuration, safe to kill.

A sweep folder holds

* `manifest.json`: everything the rows depend on (grid, episodes, seed, env, episode limit,
  the policy's SHA-256), written atomically before the first row. A resumed sweep must match
  it exactly, else the store refuses to mix results;
* `results.csv`: a header, then one row per configuration in the order they finished. Each
  row is one `write` of a whole line to a file opened for appending, followed by `fsync`.
  A kill at any instant leaves every finished row intact and at most one partial last line
  (no newline yet); opening the store cuts that partial line off, so the configuration is
  simply run again;
* `.lock`: an advisory lock held while a sweep writes, so two sweeps cannot interleave rows.

Rows are read back sorted by configuration index: a resumed sweep and an uninterrupted one give
the same rows whatever the order configurations finished in.
"""

from __future__ import annotations

import csv
import fcntl
import io
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from fluids_bench.algos.results import write_json_atomic
from fluids_bench.sweep.grid import ORDER

MANIFEST = "manifest.json"
RESULTS = "results.csv"
LOCK = ".lock"
# per-configuration outcome columns, after the index and the parameter values
OUTCOMES = ("episodes", "successes", "collisions", "timeouts", "success_rate", "mean_steps")
COLUMNS = ("index", *ORDER, *OUTCOMES)
INT_COLUMNS = {
    "index",
    "cars",
    "pedestrians",
    "lights",
    "episodes",
    "successes",
    "collisions",
    "timeouts",
}


# the rows of a sweep over any id's kwargs (manifest format 2): returns as well as successes
KWARG_OUTCOMES = (
    "episodes",
    "successes",
    "terminations",
    "truncations",
    "success_rate",
    "mean_return",
    "std_return",
    "mean_steps",
)
KWARG_INT_OUTCOMES = {"episodes", "successes", "terminations", "truncations"}


class Layout:
    """The columns of a results file and how each cell is written and read: the FLUIDS
    Sensitivity sweep's (`Layout()`, unchanged) or a kwarg grid's (`Layout.of(grid)`)."""

    def __init__(
        self,
        columns: tuple[str, ...] = COLUMNS,
        ints: set[str] | frozenset[str] = frozenset(INT_COLUMNS),
        strings: set[str] | frozenset[str] = frozenset(),
    ) -> None:
        self.columns, self.ints, self.strings = tuple(columns), frozenset(ints), frozenset(strings)

    @classmethod
    def of(cls, grid: Any) -> Layout:
        if getattr(grid, "legacy", True):
            return cls()
        kinds = grid.kinds
        return cls.from_kinds(tuple(grid.names), kinds)

    @classmethod
    def from_kinds(cls, names: tuple[str, ...], kinds: Mapping[str, str]) -> Layout:
        ints = {"index", *KWARG_INT_OUTCOMES, *(n for n in names if kinds[n] in ("int", "bool"))}
        strings = {n for n in names if kinds[n] == "str"}
        return cls(("index", *names, *KWARG_OUTCOMES), ints, strings)

    @classmethod
    def of_manifest(cls, manifest: Mapping[str, Any] | None) -> Layout:
        if manifest is None or manifest.get("format", 1) == 1:
            return cls()
        names = tuple(manifest["grid"])
        return cls.from_kinds(names, manifest["kinds"])

    def format_row(self, row: Mapping[str, Any]) -> str:
        missing = [c for c in self.columns if c not in row]
        if missing:
            raise ValueError(f"ResultStore: row lacks columns {missing}")
        cells = []
        for column in self.columns:
            value = row[column]
            if column in self.strings:
                cells.append(str(value))
            elif column in self.ints:
                cells.append(str(int(value)))
            else:
                cells.append(repr(float(value)))
        return ",".join(cells) + "\n"

    def parse_row(self, cells: list[str], where: str) -> dict[str, Any]:
        if len(cells) != len(self.columns):
            raise ValueError(f"{where}: {len(cells)} cells, expected {len(self.columns)}")
        try:
            return {
                c: v if c in self.strings else int(v) if c in self.ints else float(v)
                for c, v in zip(self.columns, cells, strict=True)
            }
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None


def format_row(row: Mapping[str, Any]) -> str:
    """One CSV line (with its newline); floats as `repr` so they read back bit-identical."""
    return Layout().format_row(row)


def _parse_row(cells: list[str], where: str) -> dict[str, Any]:
    return Layout().parse_row(cells, where)


class ResultStore:
    """The rows of one sweep folder; `open` it before appending."""

    def __init__(self, folder: str | os.PathLike[str], layout: Layout | None = None) -> None:
        self.layout = layout or Layout()
        self.folder = Path(folder)
        self.manifest_path = self.folder / MANIFEST
        self.results_path = self.folder / RESULTS
        self._fd: int | None = None
        self._lock_fd: int | None = None
        self.rows: dict[int, dict[str, Any]] = {}

    # -- manifest -----------------------------------------------------------------------------

    def read_manifest(self) -> dict[str, Any] | None:
        """The folder's manifest, None if it has none; a ValueError naming the file and what to
        do if it is not a JSON object (truncated, edited, not UTF-8)."""
        if not self.manifest_path.exists():
            return None
        try:
            manifest = json.loads(self.manifest_path.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as e:
            problem = f"is not valid JSON ({e})"
        else:
            if isinstance(manifest, dict):
                return manifest
            problem = f"holds a {type(manifest).__name__}, not a JSON object"
        raise ValueError(
            f"{self.manifest_path} {problem}; it is written atomically, so it was damaged or "
            "edited: restore it from a copy, use another --out folder, or --overwrite to "
            "discard this sweep's results"
        )

    def open(self, manifest: Mapping[str, Any], overwrite: bool = False) -> dict[int, dict]:
        """Lock the folder, check or write `manifest`, and return the finished rows.

        An existing folder with another manifest is refused (`FileExistsError`) unless
        `overwrite`, which deletes its rows first.
        """
        self.folder.mkdir(parents=True, exist_ok=True)
        self._lock()
        try:
            self.rows = self._start(json.loads(json.dumps(manifest)), overwrite)
        except BaseException:
            self.close()  # release the lock: nothing was opened for writing
            raise
        return dict(self.rows)

    def _start(self, manifest: dict[str, Any], overwrite: bool) -> dict[int, dict[str, Any]]:
        try:
            existing = self.read_manifest()
        except ValueError:
            if not overwrite:
                raise
            existing = None  # a damaged manifest is discarded with the results it described
        if existing is not None and existing != manifest and not overwrite:
            changed = sorted(
                k for k in manifest.keys() | existing.keys() if manifest.get(k) != existing.get(k)
            )
            raise FileExistsError(
                f"{self.folder} holds a sweep with other settings ({', '.join(changed)}); "
                "use another --out folder, or --overwrite to discard its results"
            )
        if existing is None and not overwrite and self.results_path.exists():
            if self.results_path.read_bytes().count(b"\n") > 1:  # a header and rows
                raise FileExistsError(
                    f"{self.results_path} has rows but no {MANIFEST}; "
                    "use another --out folder, or --overwrite to discard them"
                )
        if existing != manifest or overwrite:
            self.results_path.unlink(missing_ok=True)
            write_json_atomic(self.manifest_path, manifest)
        self._fd = os.open(self.results_path, os.O_RDWR | os.O_CREAT | os.O_APPEND, 0o644)
        return self._recover()

    def _lock(self) -> None:
        fd = os.open(self.folder / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise FileExistsError(f"another sweep is writing to {self.folder}") from None
        self._lock_fd = fd

    # -- rows ---------------------------------------------------------------------------------

    def _recover(self) -> dict[int, dict[str, Any]]:
        """Read the finished rows; cut off a partial last line (a kill mid-write)."""
        assert self._fd is not None
        data = self.results_path.read_bytes()
        complete = data[: data.rfind(b"\n") + 1]
        if len(complete) != len(data):
            os.ftruncate(self._fd, len(complete))
            os.fsync(self._fd)
        header = ",".join(self.layout.columns) + "\n"
        if not complete:
            os.write(self._fd, header.encode())
            os.fsync(self._fd)
            return {}
        lines = complete.decode().splitlines(keepends=True)
        if lines[0] != header:
            raise ValueError(f"{self.results_path}: unexpected header {lines[0].strip()!r}")
        rows: dict[int, dict[str, Any]] = {}
        for number, cells in enumerate(csv.reader(io.StringIO("".join(lines[1:]))), start=2):
            row = self.layout.parse_row(cells, f"{self.results_path}:{number}")
            previous = rows.setdefault(row["index"], row)
            if previous != row:
                raise ValueError(
                    f"{self.results_path}:{number}: configuration {row['index']} "
                    "is recorded twice with different results"
                )
        return rows

    def append(self, row: Mapping[str, Any]) -> None:
        """Record one finished configuration durably (one write, then fsync)."""
        if self._fd is None:
            raise RuntimeError("ResultStore.append: open() the store first")
        line = self.layout.format_row(row)
        os.write(self._fd, line.encode())
        os.fsync(self._fd)
        self.rows[int(row["index"])] = self.layout.parse_row(line.strip().split(","), "ResultStore")

    def sorted_rows(self) -> list[dict[str, Any]]:
        return [self.rows[i] for i in sorted(self.rows)]

    def close(self) -> None:
        for fd in (self._fd, self._lock_fd):
            if fd is not None:
                os.close(fd)  # closing releases the lock
        self._fd = self._lock_fd = None

    def __enter__(self) -> ResultStore:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def load_rows(folder: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The finished rows of a sweep folder, sorted by index, without locking or repairing it."""
    path = Path(folder) / RESULTS
    layout = Layout.of_manifest(ResultStore(folder).read_manifest())
    data = path.read_text()
    lines = data[: data.rfind("\n") + 1].splitlines()
    rows = [layout.parse_row(c, str(path)) for c in csv.reader(lines[1:])]
    return sorted({r["index"]: r for r in rows}.values(), key=lambda r: r["index"])
