"""Reproduce the source's Fig. 6.4: SHIV vs DAgger on grasping in clutter, queries to the supervisor.

The source (ch. 6): a 4-DOF arm must grasp a target without knocking obstacles off the table;
the state is the six objects' poses, the three joint angles and the gripper position; the policy
is kernel ridge regression with an RBF kernel and scikit-learn's default parameters; one initial
demonstration, then on-policy iterations in which the target's pose is resampled from an
isotropic Gaussian (std 3% of the table's width) in a fixed scene; SHIV's risk model uses
``sigma_r = 5``, ``sigma = 6`` (``nu = 0.1``, ``nu_r = 1e-3`` for all of ch. 6's experiments) and
``epsilon`` the median L2 regression error; performance = knocked off + 10 × not grasped,
normalised so that 1 is the supervisor; averaged over 8 rounds. Reported: 64% fewer queries for
SHIV than DAgger to reach the supervisor's performance.

Here: GraspingInClutter-v0 with ``layout_seed = round`` (each round its own fixed layout, the
target's position resampled every episode), the algorithmic supervisor as the teacher, and the
suite's :mod:`fluids_bench.algos` (DAgger with beta = 0, SHIV with the parameters above, every
parameter passed explicitly). Every state of a DAgger rollout is labelled; SHIV labels the risky
ones. Behavior Cloning on as many supervisor demonstrations is run as the off-policy reference. The learner is evaluated after every iteration on ``--eval-episodes`` seeded episodes, the
supervisor on the same seeds; normalised performance is ``(10 - cost) / (10 - cost_supervisor)``
(the env's return is ``10 - cost``).

Writes ``<out>/runs/<algo>_<round>.json`` per run (a rerun skips finished runs), then
``<out>/grasping_shiv.json`` (curves, means, standard errors, queries to reach the supervisor)
and ``<out>/grasping_shiv.png``, and the results file the docs read (``--results``; by default
``docs/results/reproduce_grasping_shiv<suffix>.json``, the suffix naming the settings that differ
from the source's: ``_alpha1e-3``, ``_sigma-auto``, ``_spd25``, ``_raw``). One setting (24 runs)
takes about 25–50 CPU-min. Usage: ``python scripts/reproductions/reproduce_grasping_shiv.py --workers 2``.
Needs the package importable (``pip install -e .`` or ``PYTHONPATH=.``).
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fluids_bench.algos import bc, dagger, shiv
from fluids_bench.algos.plots import new_figure, save_png_atomic
from fluids_bench.algos.policies import PolicySpec
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import command_line, machine

REPO = Path(__file__).resolve().parents[2]
CPU_SECONDS_PER_RUN = 20.0  # measured: 24 runs took 7 min on one worker (2-core machine, loaded)


ENV_ID = "GraspingInClutter-v0"
ALGOS = ("dagger", "shiv", "bc")  # BC: the off-policy reference (supervisor demonstrations)
# the source's settings (ch. 6), passed explicitly
SHIV_PARAMS = {"nu": 0.1, "sigma": 6.0, "nu_r": 1e-3, "sigma_r": 5.0, "epsilon": None}


def policy(alpha: float, standardize: bool = True) -> PolicySpec:
    """RBF kernel ridge regression; scikit-learn's defaults are alpha = 1, gamma = 1 / n_features
    (the suite's kernel_ridge family fits it on standardised features unless ``standardize`` is
    False: raw metres and radians, as scikit-learn's KernelRidge comes)."""
    return PolicySpec("kernel_ridge", {"alpha": alpha, "gamma": None}, standardize=standardize)


def bandwidth(text: str) -> float | None:
    """A bandwidth argument: a positive number, or 'auto' (None: the scale-aware default)."""
    if text == "auto":
        return None
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"bandwidth {text!r}: allowed: a number > 0 or 'auto'")
    return value


def run_one(
    algo: str,
    round_: int,
    iterations: int,
    eval_episodes: int,
    alpha: float,
    sigmas: tuple[float | None, float | None] = (SHIV_PARAMS["sigma"], SHIV_PARAMS["sigma_r"]),
    samples_per_demo: int | None = None,
    standardize: bool = True,
) -> dict[str, Any]:
    common = {
        "env_id": ENV_ID,
        "env_kwargs": {"layout_seed": round_},
        "policy": policy(alpha, standardize),
        "iterations": iterations,
        "demos_per_iteration": 1,
        "samples_per_demo": samples_per_demo,  # None: every visited state is a candidate query
        "eval_episodes": eval_episodes,
        "eval_every": 1,
        "eval_at": None,
        "max_steps": None,  # the env's time limit (100 steps)
        "return_floor": 0.0,  # return = 10 - cost, so normalised = (10 - cost) / (10 - cost*)
        "seed": round_,
    }
    start = time.process_time()
    if algo == "bc":  # one demonstration per iteration, as many as DAgger's rollouts
        result = bc.run(bc.BCConfig(**{**common, "iterations": iterations + 1}))
    elif algo == "dagger":
        config = dagger.DAggerConfig(
            **common, beta=0.0, beta_schedule="constant", initial_demos=1, retrain_at=None
        )
        result = dagger.run(config)
    else:
        params = {**SHIV_PARAMS, "sigma": sigmas[0], "sigma_r": sigmas[1]}
        config = shiv.SHIVConfig(**common, selector="shiv", initial_demos=1, **params)
        result = shiv.run(config)
    records = result.evaluated()
    return {
        "algo": algo,
        "round": round_,
        "supervisor_cost": 10.0 - result.supervisor_return,
        "iteration": [r.iteration for r in records],
        "labels": [r.labels_requested for r in records],
        "cost": [10.0 - r.eval_return for r in records],
        "normalised": [r.normalised_performance for r in records],
        "queried": [r.extras.get("queried") for r in records],
        "visited": [r.extras.get("visited") for r in records],
        "cpu_seconds": time.process_time() - start,
    }


def queries_to_reach(labels: np.ndarray, perf: np.ndarray, level: float) -> float | None:
    """Labels at which the mean curve first reaches ``level`` (linear between evaluations)."""
    for k in range(len(perf)):
        if perf[k] >= level:
            if k == 0:
                return float(labels[0])
            x0, x1, y0, y1 = labels[k - 1], labels[k], perf[k - 1], perf[k]
            return float(x0 + (level - y0) / (y1 - y0) * (x1 - x0))
    return None


def queried_share(runs: list[dict[str, Any]]) -> list[float | None]:
    """Per evaluation: the share of the visited states that were labelled, over the rounds
    (None where the learner did not query: the initial demonstration, Behavior Cloning)."""
    out = []
    for k in range(len(runs[0]["queried"])):
        queried = [r["queried"][k] for r in runs]
        visited = [r["visited"][k] for r in runs]
        if None in queried or None in visited:
            out.append(None)
        else:
            out.append(round(sum(queried) / max(1.0, sum(visited)), 4))
    return out


def summarise(runs: list[dict[str, Any]], levels: tuple[float, ...]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for algo in ALGOS:
        mine = [r for r in runs if r["algo"] == algo]
        if not mine:
            continue
        usable = [r for r in mine if None not in r["normalised"]]
        labels = np.array([r["labels"] for r in mine], dtype=float)
        cost = np.array([r["cost"] for r in mine])
        perf = np.array([r["normalised"] for r in usable], dtype=float)
        n = len(usable)
        mean_labels = labels.mean(axis=0)
        mean_perf = perf.mean(axis=0)
        out[algo] = {
            "rounds": len(mine),
            "rounds_normalised": n,
            "labels": mean_labels.round(1).tolist(),
            "normalised_mean": mean_perf.round(4).tolist(),
            "normalised_stderr": (perf.std(axis=0, ddof=1) / np.sqrt(n)).round(4).tolist()
            if n > 1
            else None,
            "cost_mean": cost.mean(axis=0).round(3).tolist(),
            "queried_share": queried_share(mine),
            "queries_to_reach": {
                str(level): queries_to_reach(mean_labels, mean_perf, level) for level in levels
            },
        }
    reductions = {}
    for level in levels:
        if "dagger" not in out or "shiv" not in out:
            break
        d, s = (out[a]["queries_to_reach"][str(level)] for a in ("dagger", "shiv"))
        reductions[str(level)] = None if d is None or s is None else round(1.0 - s / d, 4)
    out["query_reduction"] = reductions
    out["supervisor_cost_mean"] = float(np.mean([r["supervisor_cost"] for r in runs]))
    return out


def plot(
    summary: dict[str, Any], path: Path, rounds: int, alpha: float, standardize: bool = True
) -> None:
    figure = new_figure(1, 1, (6.4, 4.2))
    axes = figure.axes[0]
    names = {"dagger": "DAgger", "shiv": "SHIV (σ = 6, σ_r = 5)", "bc": "BC (off-policy)"}
    for algo, colour in zip(ALGOS, ("tab:blue", "tab:orange", "tab:gray"), strict=True):
        if algo not in summary:
            continue
        curve = summary[algo]
        x, mean = np.array(curve["labels"]), np.array(curve["normalised_mean"])
        error = np.array(curve["normalised_stderr"] or np.zeros_like(mean))
        axes.plot(x, mean, marker="o", ms=3, color=colour, label=names[algo])
        axes.fill_between(x, mean - error, mean + error, color=colour, alpha=0.2)
    axes.axhline(1.0, color="black", ls="--", lw=1, label="supervisor")
    axes.set_xlabel("queries to the supervisor (labelled states)")
    axes.set_ylabel("normalised performance")
    features = "" if standardize else ", raw features"
    axes.set_title(f"Grasping in clutter, KRR (alpha = {alpha:g}{features}), {rounds} rounds")
    save_png_atomic(figure, path, legend_loc="lower right")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("out/reproduce_grasping_shiv"))
    parser.add_argument("--rounds", type=int, default=8)
    parser.add_argument("--iterations", type=int, default=10, help="on-policy iterations")
    parser.add_argument("--eval-episodes", type=int, default=10)
    parser.add_argument("--workers", type=int, default=2, help="processes (1: run inline)")
    parser.add_argument(
        "--alpha",
        type=float,
        default=1.0,
        help="kernel ridge regularisation (default 1.0, scikit-learn's default)",
    )
    parser.add_argument(
        "--sigma",
        type=bandwidth,
        default=SHIV_PARAMS["sigma"],
        help="SHIV's sigma in raw state units (default 6, the source's), or 'auto' (standardised "
        "features, median distance between training states)",
    )
    parser.add_argument(
        "--sigma-r",
        type=bandwidth,
        default=SHIV_PARAMS["sigma_r"],
        help="SHIV's sigma_r (default 5, the source's), or 'auto' (follows sigma)",
    )
    parser.add_argument(
        "--samples-per-demo",
        type=int,
        default=None,
        help="label at most this many states drawn at random per rollout (default: every one)",
    )
    parser.add_argument(
        "--raw-features",
        action="store_true",
        help="fit kernel ridge on the raw state (metres, radians) instead of standardised features",
    )
    parser.add_argument(
        "--algos", nargs="+", choices=ALGOS, default=list(ALGOS), help="learners to run"
    )
    parser.add_argument("--png", type=Path, default=None, help="also write the plot here")
    parser.add_argument(
        "--results", type=Path, default=None,
        help="the results file the docs read (default: docs/results/reproduce_grasping_shiv"
        "<suffix>.json, the suffix naming the settings off the source's)",
    )  # fmt: skip
    args = parser.parse_args()
    if min(args.rounds, args.iterations, args.eval_episodes, args.workers) < 1:
        parser.error("--rounds, --iterations, --eval-episodes, --workers: >= 1")
    if args.samples_per_demo is not None and args.samples_per_demo < 1:
        parser.error(f"--samples-per-demo {args.samples_per_demo}: allowed: >= 1")
    standardize = not args.raw_features
    if args.results is None:
        suffix = "" if args.alpha == 1.0 else "_alpha" + f"{args.alpha:.0e}".replace("e-0", "e-")
        if (args.sigma, args.sigma_r) != (SHIV_PARAMS["sigma"], SHIV_PARAMS["sigma_r"]):
            suffix += "_sigma-auto" if args.sigma is None else f"_sigma{args.sigma:g}"
        if args.samples_per_demo is not None:
            suffix += f"_spd{args.samples_per_demo}"
        if args.raw_features:
            suffix += "_raw"
        args.results = REPO / "docs" / "results" / f"reproduce_grasping_shiv{suffix}.json"
    runs_dir = args.out / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)
    sigmas = (args.sigma, args.sigma_r)
    settings: tuple[Any, ...] = (args.iterations, args.eval_episodes, args.alpha)
    if sigmas != (SHIV_PARAMS["sigma"], SHIV_PARAMS["sigma_r"]):
        settings = (*settings, *sigmas)  # (the source's bandwidths keep older runs resumable)
    if args.samples_per_demo is not None:
        settings = (*settings, "samples_per_demo", args.samples_per_demo)
    if args.raw_features:
        settings = (*settings, "raw_features")
    jobs = [(algo, r) for r in range(args.rounds) for algo in args.algos]
    runs: dict[tuple[str, int], dict[str, Any]] = {}
    for algo, r in jobs:  # resume: keep finished runs made with the same settings
        path = runs_dir / f"{algo}_{r}.json"
        if path.exists():
            run = json.loads(path.read_text())
            if tuple(run.get("settings", ())) == settings:
                runs[(algo, r)] = run
    todo = [job for job in jobs if job not in runs]
    expected = CPU_SECONDS_PER_RUN * len(todo) * args.iterations / 10 / args.workers
    print(f"expected run time: ~{max(1, round(expected / 60))} min on {args.workers} free core(s)")
    machine_at_start = machine()

    def keep(run: dict[str, Any]) -> None:
        run["settings"] = list(settings)
        write_json_atomic(runs_dir / f"{run['algo']}_{run['round']}.json", run)
        runs[(run["algo"], run["round"])] = run

    if args.workers == 1:
        for algo, r in tqdm(todo, desc="runs"):
            keep(run_one(algo, r, *settings[:3], sigmas, args.samples_per_demo, standardize))
    else:
        with ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool:
            futures = [
                pool.submit(
                    run_one, algo, r, *settings[:3], sigmas, args.samples_per_demo, standardize
                )
                for algo, r in todo
            ]
            for future in tqdm(as_completed(futures), total=len(futures), desc="runs"):
                keep(future.result())

    levels = (0.1, 0.2, 0.3, 0.5, 0.9, 0.95, 1.0)
    ordered = [runs[job] for job in jobs]
    summary = summarise(ordered, levels)
    payload = {
        "figure": "dissertation Fig. 6.4 (SHIV vs DAgger, grasping in clutter)",
        "settings": {
            "rounds": args.rounds,
            "iterations": args.iterations,
            "eval_episodes": args.eval_episodes,
            "policy": {
                "name": "kernel_ridge",
                "params": dict(policy(args.alpha).params),
                "standardize": standardize,
            },
            "shiv": {**SHIV_PARAMS, "sigma": args.sigma, "sigma_r": args.sigma_r},
            "algos": args.algos,
            "samples_per_demo": args.samples_per_demo,
            "env": f"{ENV_ID} with layout_seed = round",
        },
        "summary": summary,
        "runs": ordered,
    }
    write_json_atomic(args.out / "grasping_shiv.json", payload)
    results_file = {
        "command": command_line(),
        "seeds": "round r: layout_seed r; see the runs' seeds",
    }
    results_file |= {k: v for k, v in payload.items() if k != "runs"} | {
        "machine": machine_at_start
    }
    args.results.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.results, results_file)
    print(f"wrote {args.results}")
    plot(summary, args.out / "grasping_shiv.png", args.rounds, args.alpha, standardize)
    if args.png is not None:
        plot(summary, args.png, args.rounds, args.alpha, standardize)
    print(json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()
