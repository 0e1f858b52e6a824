"""Show the source's Theorem 1 (ch. 4) empirically on DAG-v0 with the constant policy class {L, R}.

- On-policy: DAgger (beta = 0) after ``m`` supervisor demonstrations, then ``--iterations`` on-policy
  iterations. If the first majority vote says R, every later rollout of R adds the labels L R R
  and R stays the majority: the run ends at R, the worse policy. We measure how often runs end
  at R for m = 1..``--max-m`` and compare with the exact probability that the first vote says R,
  ``P(Binomial(m, mu) > 3m/4)`` (ties go to L), and with ``c e^{-m}`` for the largest ``c`` that
  keeps the bound under that probability on the range shown.
- Off-policy: Behavior Cloning with N supervisor demonstrations; the fraction of runs that end
  at the best constant policy L goes to 1 as N grows (law of large numbers, ``3 - 2 mu > 2 mu``).

Writes ``dag.json`` and ``dag.png`` to ``--out`` and the same JSON, with the command line, to the
results file the docs read (``--results``, default ``docs/results/reproduce_dag.json``). About
2 CPU-min at the defaults. Needs the package importable
(``pip install -e .`` or ``PYTHONPATH=.``).
"""

from __future__ import annotations

import argparse
import math
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fluids_bench.algos import bc, dagger
from fluids_bench.algos.plots import new_figure, save_png_atomic
from fluids_bench.algos.policies import PolicySpec
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import command_line, machine
from fluids_bench.tasks.dag.model import R
from fluids_bench.tasks.dag.supervisor import expected_return

REPO = Path(__file__).resolve().parents[2]
RESULTS = REPO / "docs" / "results" / "reproduce_dag.json"
CPU_SECONDS_PER_RUN = 0.004  # measured: one on- or off-policy run at 20 iterations


ROOT = np.zeros(2, dtype=np.float32)
CONSTANT = PolicySpec("constant")
# the R policy's rollout collects rewards 0 + 1 + 1; an L policy's collects 6 or 0
R_ROLLOUT_RETURN = 2.0


def first_vote_is_r_probability(m: int, mu: float) -> float:
    """``P(S > 3m/4)`` for ``S ~ Binomial(m, mu)``: more R labels (2S) than L labels (3m - 2S)."""
    return sum(math.comb(m, k) * mu**k * (1 - mu) ** (m - k) for k in range(m + 1) if 4 * k > 3 * m)


def settings(mu: float, seed: int) -> dict[str, Any]:
    """The constant policy class on DAG-v0, evaluated once, at the end (its own seeds)."""
    return {
        "env_id": "DAG-v0",
        "env_kwargs": {"mu": mu},
        "policy": CONSTANT,
        "eval_episodes": 1,
        "eval_at": (),
        "seed": seed,
    }


def on_policy_batch(m: int, seeds: list[int], iterations: int, mu: float) -> dict[str, int]:
    """Runs of DAgger with ``m`` initial demonstrations: how many start at R and end at R."""
    start_r = end_r = 0
    for seed in seeds:
        config = dagger.DAggerConfig(**settings(mu, seed), initial_demos=m, iterations=iterations)
        result = dagger.run(config)
        start_r += result.records[1].collection_return == R_ROLLOUT_RETURN
        end_r += result.policy.act(ROOT) == R
    return {"m": m, "runs": len(seeds), "start_r": int(start_r), "end_r": int(end_r)}


def off_policy_batch(n: int, seeds: list[int], mu: float) -> dict[str, int]:
    """Runs of Behavior Cloning with ``n`` demonstrations: how many end at R."""
    end_r = sum(
        bc.run(bc.BCConfig(**settings(mu, seed), iterations=n)).policy.act(ROOT) == R
        for seed in seeds
    )
    return {"n": n, "runs": len(seeds), "end_r": int(end_r)}


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95% Wilson score interval of a binomial proportion."""
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def run_batches(jobs: list[tuple[Any, ...]], function: Any, workers: int, desc: str) -> list[Any]:
    if workers == 1:
        return [function(*job) for job in tqdm(jobs, desc=desc)]
    with ProcessPoolExecutor(workers, initializer=one_blas_thread) as pool:
        futures = [pool.submit(function, *job) for job in jobs]
        return [f.result() for f in tqdm(futures, desc=desc)]


def merge(batches: list[dict[str, int]], key: str) -> list[dict[str, int]]:
    merged: dict[int, dict[str, int]] = {}
    for batch in batches:
        row = merged.setdefault(batch[key], {k: 0 for k in batch} | {key: batch[key]})
        for k, v in batch.items():
            if k != key:
                row[k] += v
    return [merged[k] for k in sorted(merged)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("out/reproduce_dag"))
    parser.add_argument("--mu", type=float, default=0.25, help="root slip (the proof uses 1/4)")
    parser.add_argument("--max-m", type=int, default=8, help="largest number of initial demos")
    parser.add_argument("--runs", type=int, default=2000, help="runs per m and per N")
    parser.add_argument("--iterations", type=int, default=20, help="on-policy iterations")
    parser.add_argument("--off-policy-n", type=int, nargs="+", default=[1, 2, 4, 8, 16, 32])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--results", type=Path, default=RESULTS, help="the results file the docs read (JSON)"
    )
    args = parser.parse_args()
    if min(args.max_m, args.runs, args.iterations, args.workers, *args.off_policy_n) < 1:
        parser.error("--max-m, --runs, --iterations, --workers and --off-policy-n must be >= 1")
    if not 0.0 < args.mu < 0.5:
        parser.error("--mu must be in (0, 0.5): L is the best constant policy only then")

    runs = args.runs * (args.max_m + len(args.off_policy_n))
    expected = CPU_SECONDS_PER_RUN * runs * args.iterations / 20 / args.workers
    print(f"expected run time: ~{max(1, round(expected / 60))} min on {args.workers} free core(s)")
    machine_at_start = machine()
    start = time.perf_counter()
    chunk = 250
    on_jobs = [
        (
            m,
            list(range(m * 1_000_000 + i, m * 1_000_000 + min(i + chunk, args.runs))),
            args.iterations,
            args.mu,
        )
        for m in range(1, args.max_m + 1)
        for i in range(0, args.runs, chunk)
    ]
    off_jobs = [
        (
            n,
            list(
                range(
                    n * 1_000_000 + 500_000 + i, n * 1_000_000 + 500_000 + min(i + chunk, args.runs)
                )
            ),
            args.mu,
        )
        for n in args.off_policy_n
        for i in range(0, args.runs, chunk)
    ]
    on_rows = merge(run_batches(on_jobs, on_policy_batch, args.workers, "on-policy"), "m")
    off_rows = merge(run_batches(off_jobs, off_policy_batch, args.workers, "off-policy"), "n")

    for row in on_rows:
        m = row["m"]
        row["exact_first_vote_r"] = first_vote_is_r_probability(m, args.mu)
        row["end_r_frequency"] = row["end_r"] / row["runs"]
        row["end_r_wilson_95"] = wilson(row["end_r"], row["runs"])
        row["start_r_frequency"] = row["start_r"] / row["runs"]
    c = min(row["exact_first_vote_r"] * math.exp(row["m"]) for row in on_rows)
    for row in on_rows:
        row["c_exp_minus_m"] = c * math.exp(-row["m"])
        row["bound_holds"] = row["end_r_wilson_95"][1] >= row["c_exp_minus_m"]
    for row in off_rows:
        row["end_l_frequency"] = 1 - row["end_r"] / row["runs"]
        row["exact_end_r"] = first_vote_is_r_probability(row["n"], args.mu)
    seconds = time.perf_counter() - start

    payload = {
        "figure": "dissertation Theorem 1 / Fig. 4.1 (DAG counter-example)",
        "settings": {k: v for k, v in vars(args).items() if k != "results"}
        | {"out": str(args.out)},
        "expected_returns": {p: expected_return(args.mu, p) for p in ("supervisor", "L", "R")},
        "c": c,
        "on_policy": on_rows,
        "off_policy": off_rows,
        "seconds": round(seconds, 1),
    }
    args.out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.out / "dag.json", payload)
    results = {
        "command": command_line(),
        "seeds": "on-policy m * 1e6 + run, off-policy N * 1e6 + 5e5 + run",
    }
    results |= payload | {"machine": machine_at_start}
    args.results.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.results, results)
    plot(on_rows, off_rows, c, args, args.out / "dag.png")
    for row in on_rows:
        print(
            f"m={row['m']}: on-policy ends at R {row['end_r']}/{row['runs']} "
            f"({row['end_r_frequency']:.4f}), first vote R {row['start_r_frequency']:.4f}, "
            f"exact {row['exact_first_vote_r']:.4f}, c e^-m {row['c_exp_minus_m']:.4f}"
        )
    for row in off_rows:
        print(f"N={row['n']}: off-policy ends at L {row['end_l_frequency']:.4f}")
    print(f"c = {c:.4f}; {seconds:.0f} s; wrote {args.out / 'dag.json'} and {args.out / 'dag.png'}")
    print(f"wrote {args.results}")


def plot(
    on_rows: list[dict[str, Any]],
    off_rows: list[dict[str, Any]],
    c: float,
    args: argparse.Namespace,
    path: Path,
) -> None:
    figure = new_figure(1, 2, (11.0, 4.2))
    left, right = figure.axes
    m = np.array([row["m"] for row in on_rows])
    freq = np.array([row["end_r_frequency"] for row in on_rows])
    low = np.array([row["end_r_wilson_95"][0] for row in on_rows])
    high = np.array([row["end_r_wilson_95"][1] for row in on_rows])
    seen = freq > 0  # a log axis cannot show 0: show the upper 95% bound instead
    left.errorbar(m[seen], freq[seen], yerr=[freq[seen] - low[seen], high[seen] - freq[seen]],
                  fmt="o", color="tab:blue", label="on-policy runs ending at R (95% CI)")  # fmt: skip
    if not seen.all():
        left.plot(m[~seen], high[~seen], "v", color="tab:blue", label="none ended at R: upper 95%")
    left.plot(m, [row["exact_first_vote_r"] for row in on_rows], "s--", color="tab:green",
              label="exact P(first vote is R)")  # fmt: skip
    left.plot(m, c * np.exp(-m), "k:", label=f"c e^-m, c = {c:.3f}")
    left.set_yscale("log")
    left.set_xlabel("m, initial supervisor demonstrations")
    left.set_ylabel("probability")
    left.set_title(f"On-policy (DAgger, beta = 0) stuck at R, mu = {args.mu}")
    n = [row["n"] for row in off_rows]
    right.plot(n, [row["end_l_frequency"] for row in off_rows], "o-", color="tab:orange",
               label="off-policy runs ending at L")  # fmt: skip
    right.plot(n, [1 - row["exact_end_r"] for row in off_rows], "s--", color="tab:green",
               label="exact P(majority is L)")  # fmt: skip
    right.set_xscale("log", base=2)
    right.set_ylim(0.0, 1.05)
    right.set_xlabel("N, supervisor demonstrations")
    right.set_title("Off-policy (Behavior Cloning) converges to L")
    save_png_atomic(figure, path)


if __name__ == "__main__":
    main()
