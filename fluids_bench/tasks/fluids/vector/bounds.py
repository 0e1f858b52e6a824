"""Limits of the vector env that protect the machine: how many worlds fit in memory, and how
long a worker may take to answer before it is reported as stopped.

`make_vec("FLUIDS-v1", 10**9, ...)` used to build worlds (about 4.5 ms and 0.45 MB each) until
the machine ran out of memory; `num_envs` is now refused up front above what the memory
available right now holds at `WORLD_BYTES` per world (twice the measured size: observations,
infos and the compiled layout's per-world arrays come on top). A worker that stops answering
(stopped by SIGSTOP, stuck) used to block `step` for ever; every wait for a worker is now
bounded by `worker_timeout` seconds.
"""

from __future__ import annotations

import math
import os
from typing import Any

from fluids_bench.core.validation import fail

WORLD_BYTES = 1 << 20  # bytes one world may take (measured: about 0.45 MB)
DEFAULT_WORKER_TIMEOUT = 600.0  # s; a cold kernel compile in a spawned worker takes ~2 min


def available_memory() -> int:
    """Bytes of memory available to new allocations now (Linux's MemAvailable, else the free
    physical pages; 0 when neither can be read: no bound is then applied)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 0


def max_num_envs(memory: int | None = None) -> int | None:
    """The most worlds that fit in `memory` bytes (default: available now), or None when the
    available memory is unknown."""
    memory = available_memory() if memory is None else memory
    return max(1, memory // WORLD_BYTES) if memory > 0 else None


def check_num_envs(where: str, num_envs: int) -> None:
    """ValueError naming `num_envs` when more worlds are asked for than fit in memory."""
    limit = max_num_envs()
    if limit is not None and num_envs > limit:
        gib = available_memory() / 2**30
        fail(
            where,
            "num_envs",
            num_envs,
            f"an integer in [1, {limit}] (about {WORLD_BYTES >> 20} MiB per world; "
            f"{gib:.1f} GiB of memory is available now)",
        )


def check_worker_timeout(where: str, value: Any) -> float | None:
    """`worker_timeout`: None (wait for ever) or a finite number of seconds > 0."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        fail(where, "worker_timeout", value, "None or a finite number of seconds > 0")
    if value <= 0:
        fail(where, "worker_timeout", value, "None or a finite number of seconds > 0")
    return float(value)


def process_state(pid: int) -> str:
    """One word for process `pid`'s state from Linux's /proc ('stopped' for SIGSTOP), or ''."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            code = f.read().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return ""
    names = {"R": "running", "S": "sleeping", "D": "waiting on the disk", "Z": "dead"}
    return {"T": "stopped", "t": "stopped", **names}.get(code, "")
