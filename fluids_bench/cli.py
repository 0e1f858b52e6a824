"""The ``fluids-bench`` command line.

Each subcommand lives in its own module under :mod:`fluids_bench.commands` and exposes
``add_parser(subparsers)``, which registers the subcommand and sets ``func`` (taking the parsed
args, returning an exit code). Modules are imported lazily so that ``--help`` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import sys

# subcommand modules, in the order --help lists them
COMMAND_MODULES = (
    "fluids_bench.commands.demo",
    "fluids_bench.commands.render_layout",
    "fluids_bench.commands.train",
    "fluids_bench.commands.collect",
    "fluids_bench.commands.sweep",
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


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (ValueError, FileExistsError, FileNotFoundError) as exc:
        print(f"fluids-bench {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
