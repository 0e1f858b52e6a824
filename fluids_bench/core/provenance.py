"""Where a result came from: the command line that produced it and the machine it ran on.

Every script that writes a results file for the docs (`docs/results/*.json`) stores both, so a
number on a page carries its command, seeds and machine.
"""

from __future__ import annotations

import os
import platform
import shlex
import sys
from pathlib import Path


def command_line() -> str:
    """The running script's command line, its path shown from the repository's `scripts/`."""
    script = Path(sys.argv[0]).resolve()
    parts = script.parts
    shown = (
        "/".join(parts[len(parts) - 1 - parts[::-1].index("scripts") :])
        if "scripts" in parts
        else sys.argv[0]
    )
    return " ".join(["python", shown, *map(shlex.quote, relative_paths(sys.argv[1:]))])


def relative_paths(args: list[str]) -> list[str]:
    """`args` with every absolute path (`/a/b`, `--out=/a/b`) shown relative to the working
    directory: a results file records no machine's folders, and the command reruns from a
    checkout anywhere."""

    def shown(arg: str) -> str:
        option, eq, value = arg.partition("=") if arg.startswith("-") else ("", "", arg)
        if os.path.isabs(value):
            return option + eq + os.path.relpath(value)
        name, named, path = value.partition("=")  # NAME=/a/b, as in --policy task=/a/b
        if named and os.path.isabs(path):
            return option + eq + name + "=" + os.path.relpath(path)
        return arg

    return [shown(a) for a in args]


def machine() -> str:
    """Cores, architecture and the load average now (results measured under load say so)."""
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return f"{os.cpu_count()} cores ({platform.machine()}), load average {load:.1f} at the start"


def announce(expected: str) -> None:
    """Say up front how long a script runs (on standard error: benchmarks print JSON on stdout)."""
    print(f"expected run time: {expected}", file=sys.stderr, flush=True)
