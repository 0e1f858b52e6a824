"""Learning curves on FLUIDS that can show a trend: BC, DAgger and DART with success rate,
collisions and standard errors over enough evaluation episodes, labels counted apart.

``FLUIDS-Sensitivity-v0`` (quasi-LIDAR to the ego's target velocity, 3 cars and 2 pedestrians,
success = every car arrived without a collision), episodes capped at ``--max-steps``. Each
algorithm collects one demonstration per iteration for ``--iterations`` iterations (DAgger after
one initial supervisor demonstration, beta = 0) and is evaluated at ``--eval-at`` on
``--eval-episodes`` seeded episodes; DART refits its noise after iterations 2 and 8 (ch. 3),
estimating it on the pairs left over by the 50-per-demonstration subsampling. Every learner is a
decision tree of depth 10 (``--max-depth``).

Every algorithm runs with ``--seeds`` training seeds (0, 1, ...: different demonstrations and
evaluation episodes); the table gives, per number of demonstrations, the mean over seeds of the
success rate with the standard error across seeds, next to the mean within-seed standard error
(from the evaluation episodes alone). Each run is saved to ``--out/runs/<algo>_seed<k>.json``
when it finishes, so an interrupted run resumes. Writes ``fluids_curves.json`` and
``fluids_curves.png`` (against demonstrations, the source's trajectory-level axis) to ``--out``.
Needs the package importable (``PYTHONPATH=.``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fluids_bench.algos.evaluation import standard_error
from fluids_bench.algos.plots import new_figure, save_png_atomic
from fluids_bench.algos.policies import PolicySpec
from fluids_bench.algos.registry import run_algorithm
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import relative_paths

ENV_ID = "FLUIDS-Sensitivity-v0"
ALGOS: dict[str, dict[str, Any]] = {
    "bc": {},
    "dagger": {"beta": 0.0, "beta_schedule": "constant", "initial_demos": 1},
    "dart": {"update_at": (2, 8), "heldout_fraction": 0.0, "alpha": None},
}


def run_one(
    name: str,
    seed: int,
    folder: Path,
    iterations: int,
    eval_at: tuple[int, ...],
    episodes: int,
    **rest: Any,
) -> dict[str, Any]:
    """One algorithm's run (or its saved result when the settings match)."""
    settings = {
        "env_id": ENV_ID,
        "iterations": iterations,
        "eval_at": eval_at,
        "eval_episodes": episodes,
        "max_steps": rest["max_steps"],
        "return_floor": -1.0,  # one collision step; progress adds up to 1
        "samples_per_demo": 50,
        "seed": seed,
        **ALGOS[name],
    }
    key = json.loads(json.dumps({**settings, "max_depth": rest["max_depth"]}))
    path = folder / f"{name}_seed{seed}.json"
    if path.exists():
        saved = json.loads(path.read_text())
        if saved.get("settings") == key:
            return saved["result"]
    policy = PolicySpec("tree", {"max_depth": rest["max_depth"]})
    if name == "dagger":  # DAgger's iteration k has k + 1 demonstrations: compare at equal data
        settings["iterations"] = iterations - 1
        settings["eval_at"] = tuple(k - 1 for k in eval_at)
    result = run_algorithm(name, policy=policy, **settings).to_dict()
    write_json_atomic(path, {"settings": key, "result": result})
    return result


ROW_FIELDS = ("success_rate", "collisions", "normalised", "train_seconds", "wall_seconds")


def rows_of(payload: dict[str, Any], seed: int) -> list[dict[str, Any]]:
    return [
        {
            "algo": payload["algo"],
            "seed": seed,
            "demonstrations": r["demonstrations"],
            "training_labels": r["training_labels"],
            "estimation_labels": r["estimation_labels"],
            "success_rate": r["eval_success_rate"],
            "success_se": r["eval_success_se"],
            "collisions": r["eval_collisions"],
            "normalised": r["normalised_performance"],
            "train_seconds": r["train_seconds"],
            "wall_seconds": r["wall_seconds"],
        }
        for r in payload["records"]
        if r["eval_return"] is not None
    ]


def summarise(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per algorithm and number of demonstrations: means over seeds, standard errors across."""
    table = []
    for key in sorted({(r["algo"], r["demonstrations"]) for r in rows}):
        group = [r for r in rows if (r["algo"], r["demonstrations"]) == key]
        entry: dict[str, Any] = {"algo": key[0], "demonstrations": key[1], "seeds": len(group)}
        for name in ("training_labels", "estimation_labels"):
            entry[name] = float(np.mean([r[name] for r in group]))
        for name in ROW_FIELDS:
            values = [r[name] for r in group if r[name] is not None]
            entry[name] = float(np.mean(values)) if values else None
            entry[f"{name}_se"] = standard_error(values)
        within = [r["success_se"] for r in group if r["success_se"] is not None]
        entry["success_se_within_seed"] = float(np.mean(within)) if within else None
        table.append(entry)
    return table


def plot(table: list[dict[str, Any]], supervisor_success: float | None, path: Path) -> None:
    figure = new_figure(1, 2, (11.0, 4.2))
    success, normalised = figure.axes
    for algo in ALGOS:
        entries = [e for e in table if e["algo"] == algo]
        x = [e["demonstrations"] for e in entries]
        for axes, name in ((success, "success_rate"), (normalised, "normalised")):
            axes.errorbar(
                x,
                [np.nan if e[name] is None else e[name] for e in entries],
                yerr=[e[f"{name}_se"] or 0.0 for e in entries],
                marker="o",
                capsize=3,
                label=algo,
            )
    if supervisor_success is not None:
        success.axhline(supervisor_success, color="black", ls="--", lw=1, label="supervisor")
    normalised.axhline(1.0, color="black", ls="--", lw=1, label="supervisor")
    seeds = table[0]["seeds"] if table else 0
    success.set_title(f"{ENV_ID}: success rate ({seeds} seeds, bars: s.e. across seeds)")
    normalised.set_title("normalised performance (progress − collisions)")
    for axes in figure.axes:
        axes.set_xlabel("demonstrations")
    save_png_atomic(figure, path, legend_loc="best")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("out/fluids_curves"))
    parser.add_argument("--iterations", type=int, default=10, help="demonstrations per run")
    parser.add_argument("--eval-at", type=int, nargs="+", default=[2, 5, 10])
    parser.add_argument("--eval-episodes", type=int, default=50)
    parser.add_argument("--max-steps", type=int, default=400)
    parser.add_argument("--max-depth", type=int, default=10)
    parser.add_argument("--seeds", type=int, default=5, help="training seeds per algorithm")
    parser.add_argument("--workers", type=int, default=2, help="processes (1: run inline)")
    parser.add_argument(
        "--results",
        type=Path,
        default=Path("docs/results/fluids_curves.json"),
        help="where the docs read the summary (besides --out)",
    )
    args = parser.parse_args()
    print("expected run time: ~3 min on 2 free cores (5 seeds; finished runs are reused)")
    if min(args.iterations, args.eval_episodes, args.max_steps, args.seeds, args.workers) < 1:
        parser.error("--iterations, --eval-episodes, --max-steps, --seeds, --workers: >= 1")
    if sorted(set(args.eval_at)) != args.eval_at or not 2 <= args.eval_at[0]:
        parser.error("--eval-at: increasing demonstration counts >= 2")
    if args.eval_at[-1] > args.iterations:
        parser.error("--eval-at: at most --iterations")

    for name, extra in ALGOS.items():
        print(f"{name}: {extra}")
    folder = args.out / "runs"
    common = {
        "iterations": args.iterations,
        "eval_at": tuple(args.eval_at),
        "episodes": args.eval_episodes,
        "max_steps": args.max_steps,
        "max_depth": args.max_depth,
    }
    jobs = [(name, seed) for seed in range(args.seeds) for name in ALGOS]
    start = time.perf_counter()
    if args.workers == 1:
        payloads = [run_one(n, s, folder, **common) for n, s in tqdm(jobs, desc="runs")]
    else:
        with ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool:
            futures = [pool.submit(run_one, n, s, folder, **common) for n, s in jobs]
            payloads = [f.result() for f in tqdm(futures, desc="runs")]
    seconds = time.perf_counter() - start
    rows = [row for (_, seed), p in zip(jobs, payloads, strict=True) for row in rows_of(p, seed)]
    table = summarise(rows)
    supervisor = [p["supervisor_metrics"].get("success_rate") for p in payloads]
    supervisor_success = None if None in supervisor else float(np.mean(supervisor))

    args.out.mkdir(parents=True, exist_ok=True)
    summary = {
        "command": "python "
        + " ".join(
            ["scripts/reproductions/fluids_learning_curves.py", *relative_paths(sys.argv[1:])]
        ),
        "settings": {**common, "eval_at": list(args.eval_at), "seeds": args.seeds},
        "env_id": ENV_ID,
        "algorithms": json.loads(json.dumps(ALGOS)),
        "supervisor_success_rate": supervisor_success,
        "seconds": round(seconds, 1),
        "summary": table,
        "rows": rows,
    }
    write_json_atomic(args.out / "fluids_curves.json", summary)
    args.results.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.results, {k: v for k, v in summary.items() if k != "rows"})
    plot(table, supervisor_success, args.out / "fluids_curves.png")

    def show(value: float | None, digits: int = 2) -> str:
        return "n/a" if value is None else f"{value:.{digits}f}"

    print(f"supervisor success rate (mean over seeds): {show(supervisor_success)}")
    for e in table:
        print(
            f"{e['algo']:7s} {e['demonstrations']:3d} demos  success {show(e['success_rate'])} "
            f"± {show(e['success_rate_se'])} (within seed ± {show(e['success_se_within_seed'])})"
            f"  collisions/ep {show(e['collisions'])}  normalised {show(e['normalised'], 3)} "
            f"± {show(e['normalised_se'], 3)}  labels {e['training_labels']:.0f} train + "
            f"{e['estimation_labels']:.0f} noise  fit {show(e['train_seconds'])} s, "
            f"total {show(e['wall_seconds'])} s"
        )
    print(f"{seconds:.0f} s; wrote {args.out / 'fluids_curves.json'} and .png")


if __name__ == "__main__":
    main()
