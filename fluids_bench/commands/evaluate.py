"""`fluids-bench evaluate`: a policy on the benchmark's test and OOD sets, to a scorecard.

The policy, the random policy and the supervisor run every episode of every set (the score is
normalised on the same episodes); each finished episode is appended to OUT/episodes/, so
Ctrl-C keeps it and the same command continues. The scorecard (JSON, written atomically) and
its plot go to OUT/scorecard_<name>.json and .png (the JSON to --scorecard if given).
`--episodes N` and `--tasks` run a shortened evaluation, labelled so in the scorecard.
Example:

    fluids-bench evaluate --policy supervisor --episodes 5 --tasks gridworld hopper \\
        --out out/evaluate --workers 2

POLICY: random, supervisor, module:factory (an object with act(obs)), a `fluids-bench train`
result .json (its run is replayed to rebuild the learner), an SB3 model .zip, or a learner
checkpoint; TASK=POLICY (repeatable) gives each task its own.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from fluids_bench.commands import plain_text


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from fluids_bench.benchmark.suite import TASK_NAMES

    parser = subparsers.add_parser(
        "evaluate",
        help="evaluate a policy on the benchmark's test and OOD sets; write a scorecard",
        description=plain_text(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--policy", required=True, action="append", metavar="POLICY|TASK=POLICY",
        help="the policy (see above); TASK=POLICY, repeated, for one policy per task",
    )  # fmt: skip
    parser.add_argument("--name", default=None, help="the policy's name (default: from POLICY)")
    parser.add_argument(
        "--tasks", nargs="+", default=None, metavar="TASK",
        help=f"evaluate only these tasks (a shortened suite): {', '.join(TASK_NAMES)}",
    )  # fmt: skip
    parser.add_argument(
        "--episodes", type=int, default=None,
        help="the first N episodes of each set (a shortened suite; default: all)",
    )  # fmt: skip
    parser.add_argument("--out", type=Path, default=Path("out/evaluate"), help="output folder")
    parser.add_argument("--scorecard", type=Path, default=None, help="scorecard path (.json)")
    parser.add_argument("--workers", type=int, default=1, help="processes (default 1: here)")
    parser.add_argument(
        "--batch", type=int, default=32,
        help="FLUIDS episodes stepped together on the vector env where the policy acts on a "
        "batch (same rows; 1: one by one; default 32)",
    )  # fmt: skip
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    parser.add_argument("--no-plots", action="store_true", help="write no PNG")
    parser.set_defaults(func=main)


def _policy(values: list[str]) -> object:
    from fluids_bench.benchmark.suite import TASK_NAMES

    pairs = [v.partition("=") for v in values]
    per_task = [(k, p) for k, sep, p in pairs if sep and k in TASK_NAMES]
    if len(values) == 1 and not per_task:
        return values[0]
    if len(per_task) != len(values):
        bad = [
            v for v, (k, sep, _) in zip(values, pairs, strict=True) if not (sep and k in TASK_NAMES)
        ]
        raise ValueError(
            f"--policy {bad[0]!r}: with several --policy, each is TASK=POLICY with TASK one of "
            f"{', '.join(TASK_NAMES)}"
        )
    return dict(per_task)


def main(args: argparse.Namespace) -> int:
    from fluids_bench.benchmark.evaluator import evaluate
    from fluids_bench.benchmark.suite import SUITE

    policy = _policy(args.policy)
    if isinstance(policy, dict) and args.tasks is not None:
        raise ValueError("--tasks and TASK=POLICY: give one or the other")
    suite = SUITE.select(args.episodes, args.tasks)
    command = " ".join(["fluids-bench", *map(shlex.quote, sys.argv[1:])])
    card = evaluate(
        policy,
        suite,
        args.out,
        name=args.name,
        workers=args.workers,
        batch=args.batch,
        progress=not args.no_progress,
        plots=not args.no_plots,
        scorecard=args.scorecard,
        command=command,
    )
    name = card["policy"]["name"]
    for task, entry in card["tasks"].items():
        for set_name, scores in entry["sets"].items():
            norm = scores["normalised"]
            text = "n/a" if norm is None else f"{norm[0]:.3f} [{norm[1]:.3f}, {norm[2]:.3f}]"
            success = scores.get("success")
            extra = "" if success is None else f", success {success[0]:.2f}"
            print(f"{name} {task}/{set_name}: normalised {text}{extra} ({scores['episodes']} ep)")
    test = card["aggregate"]["test"]
    if test:
        print(
            f"{name} suite (test): mean {test['mean'][0]:.3f} [{test['mean'][1]:.3f}, "
            f"{test['mean'][2]:.3f}], IQM {test['iqm'][0]:.3f} [{test['iqm'][1]:.3f}, "
            f"{test['iqm'][2]:.3f}]" + (" (shortened)" if card["shortened"] else "")
        )
    path = args.scorecard or args.out / f"scorecard_{name}.json"
    print(f"wrote {path}")
    return 0
