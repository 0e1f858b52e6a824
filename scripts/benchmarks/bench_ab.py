"""Run a benchmark script side by side on two versions of the code, as JSON.

The shared machines' speed drifts (up to 2x over minutes), so a number measured today does not
compare with one measured yesterday. This runs ``BENCH`` (this tree's version of the script, so
both sides are measured the same way) alternately against a git revision's ``fluids_bench``
(checked out in a temporary worktree) and the working tree's, pinned to one core; it reports
every run
and the medians of the numbers the benchmark prints (any key ending in ``per_s`` or
``per_cpu_s``), with the ratio now / base:

    python scripts/benchmarks/bench_ab.py --base HEAD~3 --runs 5 -- bench_sim.py --only S2 --steps 3000
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from fluids_bench.core.provenance import announce

HERE = Path(__file__).resolve().parent  # scripts/benchmarks: the scripts it can run
ROOT = HERE.parents[1]
RATE_SUFFIXES = ("per_s", "per_cpu_s")


# the keys that name an entry of a list of measurements (e.g. bench_vector's "batch" rows)
ROW_NAMES = ("env", "num_envs", "agents")


def rates(result, prefix: str = "") -> dict[str, float]:
    """Every throughput figure in a benchmark's JSON, keyed by its path (an entry of a list
    by its index, or by its ``env``, ``num_envs`` and ``agents`` where it has them)."""
    out: dict[str, float] = {}
    if isinstance(result, list):
        for i, item in enumerate(result):
            name = i
            if isinstance(item, dict) and any(k in item for k in ROW_NAMES):
                name = ",".join(f"{k}={item[k]}" for k in ROW_NAMES if k in item)
            out.update(rates(item, f"{prefix}[{name}]"))
    elif isinstance(result, dict):
        for key, value in result.items():
            path = f"{prefix}/{key}" if prefix else str(key)
            if isinstance(value, int | float) and str(key).endswith(RATE_SUFFIXES):
                out[path] = float(value)
            else:
                out.update(rates(value, path))
    return out


def run(tree: Path, bench: list[str], core: int) -> dict[str, float]:
    """One run of this tree's benchmark script against ``tree``'s fluids_bench."""
    env = {**os.environ, "PYTHONPATH": str(tree)}  # ahead of any installed fluids_bench
    cmd = ["taskset", "-c", str(core), sys.executable, str(HERE / bench[0]), *bench[1:]]
    done = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True, check=False)
    if done.returncode:
        raise SystemExit(f"bench_ab: {' '.join(cmd)} failed in {tree}:\n{done.stderr[-2000:]}")
    return rates(json.loads(done.stdout))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", required=True, help="git revision to compare against")
    parser.add_argument("--runs", type=int, default=5, help="alternated runs of each version")
    parser.add_argument("--core", type=int, default=0, help="CPU core to pin every run to")
    parser.add_argument(
        "bench", nargs=argparse.REMAINDER, help="-- SCRIPT [ARGS]: a script in scripts/benchmarks/"
    )
    args = parser.parse_args()
    announce("2 x --runs times the benchmark's own run time")
    bench = args.bench[1:] if args.bench[:1] == ["--"] else args.bench
    if not bench or not (HERE / bench[0]).is_file():
        parser.error(f"benchmark is {bench[:1]}; allowed: a script in {HERE}, after --")
    if args.runs < 1:
        parser.error(f"--runs is {args.runs}; allowed: 1 or more")
    with tempfile.TemporaryDirectory(prefix="bench_ab_") as tmp:
        base_tree = Path(tmp) / "base"
        subprocess.run(
            [
                "git",
                "-C",
                str(ROOT),
                "worktree",
                "add",
                "--detach",
                "--quiet",
                str(base_tree),
                args.base,
            ],
            check=True,
        )
        try:
            runs: dict[str, list[dict[str, float]]] = {"base": [], "now": []}
            for _ in range(args.runs):  # alternate, so drift hits both versions alike
                runs["base"].append(run(base_tree, bench, args.core))
                runs["now"].append(run(ROOT, bench, args.core))
        finally:
            subprocess.run(
                ["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base_tree)],
                check=False,
            )
    keys = [k for k in runs["now"][0] if all(k in r for r in runs["base"] + runs["now"])]
    median = {v: {k: statistics.median(r[k] for r in runs[v]) for k in keys} for v in runs}
    print(
        json.dumps(
            {
                "benchmark": bench,
                "base": args.base,
                "runs": runs,
                "median": median,
                "ratio": {
                    k: round(median["now"][k] / median["base"][k], 3)
                    for k in keys
                    if median["base"][k]
                },
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
