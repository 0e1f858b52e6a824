"""What every benchmark script adds to its JSON when asked for a results file (``--results``).

``add_results_option(parser)`` adds ``--results PATH``; ``emit(payload, args)`` prints the JSON and,
with ``--results``, writes it atomically to PATH with the exact command line and the machine it
ran on (processor, CPU count, load average before and after the run): the docs' speed tables
read those files (``docs/_gen/tables/bench_*.py``). Speeds from a shared machine only compare
within one run.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import sys

from fluids_bench.algos.results import write_json_atomic

_LOAD_AT_START = os.getloadavg()


def add_results_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--results",
        default=None,
        metavar="PATH",
        help="also write the JSON, the command and the machine to PATH (e.g. docs/results/<name>.json)",
    )


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> dict:
    return {
        "processor": platform.processor() or platform.machine(),
        "cpu_model": _cpu_model(),
        "cpu_count": os.cpu_count(),
        "affinity": sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "load_average_at_start": [round(x, 2) for x in _LOAD_AT_START],
        "load_average_at_end": [round(x, 2) for x in os.getloadavg()],
        "python": platform.python_version(),
    }


def emit(payload: dict, args: argparse.Namespace, indent: int = 2) -> None:
    """Print ``payload`` as JSON; with ``--results``, write it with "command" and "machine"."""
    print(json.dumps(payload, indent=indent))
    if getattr(args, "results", None):
        script = os.path.relpath(os.path.abspath(sys.argv[0]))
        if script.startswith(".."):
            script = "scripts/benchmarks/" + os.path.basename(sys.argv[0])
        command = " ".join(["python", script, *map(shlex.quote, sys.argv[1:])])
        write_json_atomic(args.results, {"command": command, "machine": machine(), **payload})
