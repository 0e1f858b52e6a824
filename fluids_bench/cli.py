"""The `fluids-bench` command line.

Each subcommand lives in its own module under `fluids_bench.commands` and exposes
`add_parser(subparsers)`, which registers the subcommand and sets `func` (taking the parsed
args, returning an exit code). Modules are imported lazily so that `--help` stays fast.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import sys
import threading

from fluids_bench.core.parallel import interrupted

# subcommand modules, in the order --help lists them
COMMAND_MODULES = (
    "fluids_bench.commands.demo",
    "fluids_bench.commands.render_layout",
    "fluids_bench.commands.train",
    "fluids_bench.commands.collect",
    "fluids_bench.commands.evaluate",
    "fluids_bench.commands.sweep",
    "fluids_bench.commands.teleop",
    "fluids_bench.commands.relabel",
    "fluids_bench.commands.export",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fluids-bench",
        description="Imitation-learning benchmark suite centred on the FLUIDS driving simulator.",
    )
    from fluids_bench import __version__

    parser.add_argument("--version", action="version", version=f"fluids-bench {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_parser(sub)
    return parser


SEED_MAX = 2**32 - 1  # numpy's and Gymnasium's seeds: non-negative, 32 bits here


def check_seeds(args: argparse.Namespace) -> None:
    """Every `--…seed` option must be a seed Gymnasium and numpy accept: refuse a negative or
    too large one before the command starts (not deep inside an env's reset)."""
    for name, value in vars(args).items():
        if name.endswith("seed") and isinstance(value, int) and not 0 <= value <= SEED_MAX:
            option = "--" + name.replace("_", "-")
            raise ValueError(f"{option} is {value}; allowed: an integer in [0, {SEED_MAX}]")


def os_error_message(exc: OSError) -> str:
    """One line for an operating-system error (disk full, permissions, ...)."""
    where = f" writing {exc.filename}" if exc.filename else ""
    reason = exc.strerror or str(exc)
    # pyarrow (Minari's writer) raises OSErrors without errno, the reason only in the text
    if exc.errno in (errno.ENOSPC, errno.EDQUOT) or "No space left on device" in str(exc):
        return f"no space left on the device{where} ({reason}); free some space, or write elsewhere"
    return f"{reason}{where}"


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    where = f"fluids-bench {args.command}"
    try:
        check_seeds(args)
        return int(args.func(args) or 0)
    except (ValueError, FileExistsError, FileNotFoundError) as exc:
        print(f"{where}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"{where}: error: {os_error_message(exc)}", file=sys.stderr)
        return 1
    except (KeyboardInterrupt, SystemError) as exc:
        if not interrupted(exc):
            raise
        # finished work is kept: collect writes nothing partial, sweep resumes where it stopped
        print(f"{where}: interrupted", file=sys.stderr)
        return 130


EXIT_GRACE = 10.0  # s the exit handlers get after Ctrl-C before the process ends regardless


def entry() -> None:
    """The `fluids-bench` command: `main`, then exit with its code.

    After Ctrl-C, Python's exit handlers run as usual (they release the pool's semaphores), but
    a daemon timer ends the process after `EXIT_GRACE` seconds if they have not finished:
    in two of about ten loaded full test runs an interrupted `collect --workers 2` had not
    exited a minute later, and Ctrl-C must end the program. Nothing is lost either way:
    finished work is on disk (collect writes atomically, sweeps resume) and pool workers die
    with their parent (`fluids_bench.core.parallel`)."""
    code = main()
    if code == 130:
        timer = threading.Timer(EXIT_GRACE, os._exit, args=(code,))
        timer.daemon = True
        timer.start()
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    entry()
