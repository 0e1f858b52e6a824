"""Reproduce the source's ch. 5 experiment 1 (Fig. 5.3): off- vs on-policy on singulation.

Every run (``--runs``, seeds 0, 1, ...) trains four learners on Singulation-v0 (state
observation) with the algorithmic supervisor as the teacher and evaluates each on the same
``--eval-episodes`` (30) held-out initial states, as success rate:

* ``bc``: Behavior Cloning, 20 supervisor demonstrations, then 40 more (off-policy, the
  source's teleoperation arm);
* ``dagger``: 20 supervisor demonstrations, then K = 2 on-policy iterations of 20 rollouts of
  the learner, every visited state labelled by the supervisor (beta = 0);
* ``dagger_retro``: as ``dagger``, but the on-policy labels pass through the retroactive
  labelling model of :mod:`fluids_bench.tasks.singulation.label_noise`, calibrated on the run's
  20 teleoperated demonstrations to the source's measured correlations (0.60 rotation, 0.22
  translation): the source's human on-policy arm;
* ``dart``: 20 noise-free demonstrations, then 40 with DART's noise, re-estimated after the
  20th and 40th (Eq. 3 on held-out pairs, 10% of each demonstration's pairs held out).

The source reports ~60% (off-policy) vs ~40% (on-policy) after 60 demonstrations with human
teachers. Every algorithm parameter is set here explicitly. Each (run, arm) result is written
to ``--out/runs/`` atomically as it finishes, so an interrupted run resumes where it stopped;
``summary.json`` and ``singulation_fig5_3.png`` are rebuilt from all results at the end, and so
is the results file the docs read (``--results``, default
``docs/results/reproduce_singulation.json`` for the default policy and evaluation size: the
command line, settings, the summary and every (run, arm) result). About 34 CPU-s per (run, arm): the four arms and the
two ablations at 10 runs are ~2,000 CPU-s.
Quick run: ``python scripts/reproductions/reproduce_singulation.py --runs 2 --eval-episodes 10``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fluids_bench.algos import bc, dagger, dart
from fluids_bench.algos.actors import SUPERVISOR, LearnerActor, MixtureActor
from fluids_bench.algos.harness import Harness
from fluids_bench.algos.plots import new_figure, save_png_atomic
from fluids_bench.algos.policies import PolicySpec
from fluids_bench.algos.results import RunResult, write_json_atomic
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import command_line, machine
from fluids_bench.tasks.singulation.label_noise import (
    SOURCE_CORRELATIONS,
    RetroactiveLabelModel,
    calibrate,
    pearson,
)

REPO = Path(__file__).resolve().parents[2]
CPU_SECONDS_PER_RUN_ARM = 13.5  # measured: 60 (run, arm) results took 800 CPU-s


ARMS = ("bc", "dagger", "dagger_retro", "dart")
# ablations of the retroactive-label model (not run by default): only its shrinkage of the
# label towards the mean, or only its added noise
ABLATIONS = ("dagger_shrink_only", "dagger_noise_only")
RETRO_MODES = {"dagger_retro": "full", "dagger_shrink_only": "shrink", "dagger_noise_only": "noise"}
INITIAL = 20  # teleoperated demonstrations before the arms differ
PER_ITERATION = 20
K = 2  # on-policy iterations of 20 (the source's K = 2)
POLICIES = {
    # the source's learner is a deep network; ours sees the 18-d state
    "mlp": PolicySpec(
        "mlp",
        {
            "hidden_layer_sizes": (64, 64),
            "alpha": 1e-4,
            "learning_rate_init": 1e-3,
            "max_iter": 500,
        },
    ),
    "knn": PolicySpec("knn", {"n_neighbors": 5}),
    "tree": PolicySpec("tree", {"max_depth": 100}),
}


def common(run: int, eval_episodes: int, policy: str) -> dict[str, Any]:
    return {
        "env_id": "Singulation-v0",
        "env_kwargs": {},
        "policy": POLICIES[policy],
        "samples_per_demo": None,  # every state-label pair of every rollout
        "eval_episodes": eval_episodes,
        "eval_every": 1,  # unused: every arm sets eval_at
        "max_steps": None,  # the registration's 150-step limit
        "return_floor": 0.0,  # return = success (reward 1 on singulation, then the end)
        "seed": run,
    }


def retroactive(
    model: RetroactiveLabelModel, labels: np.ndarray, rng: np.random.Generator, mode: str
) -> np.ndarray:
    """The model's retroactive labels ("full"), or one of its two parts alone: "shrink"
    (``mu + rho (y - mu)``, no noise) or "noise" (``y + sqrt(1 - rho^2) sigma eps``)."""
    if mode == "full":
        return model.corrupt(labels, rng)
    y = np.asarray(labels, dtype=np.float64)
    eps = rng.standard_normal(y.shape)
    if mode == "shrink":
        out = model.mu + model.rho * (y - model.mu)
    else:
        out = y + np.sqrt(1.0 - model.rho**2) * model.sigma * eps
    return np.clip(out, model.low, model.high).astype(np.asarray(labels).dtype)


def dagger_retroactive(
    config: dagger.DAggerConfig, mode: str = "full"
) -> tuple[RunResult, list[float]]:
    """DAgger whose on-policy labels are retroactive (the label-noise model); returns the run
    and the measured correlations of the corrupted with the clean on-policy labels."""
    with Harness("dagger_retro", config) as harness:
        demos = [harness.collect(SUPERVISOR) for _ in range(config.initial_demos)]
        for demo in demos:
            harness.aggregate(demo)
        reference = np.concatenate([d.labels for d in demos]).astype(np.float64)
        model = calibrate(reference, SOURCE_CORRELATIONS, seed=config.seed)
        policy = harness.fit()
        harness.record(0, demos, beta=1.0)
        clean, noisy = [], []
        for iteration in range(1, config.iterations + 1):
            actor = MixtureActor(0.0, LearnerActor(policy))
            rollouts = [harness.collect(actor) for _ in range(config.demos_per_iteration)]
            for trajectory in rollouts:
                labels = retroactive(model, trajectory.labels, harness.rng, mode)
                clean.append(trajectory.labels)
                noisy.append(labels)
                harness.aggregate(dataclasses.replace(trajectory, labels=labels))
            policy = harness.fit()
            harness.record(iteration, rollouts, beta=0.0)
        measured = pearson(np.concatenate(noisy), np.concatenate(clean)).round(3).tolist()
        return harness.result(), measured


def run_arm(run: int, arm: str, eval_episodes: int, policy: str) -> dict[str, Any]:
    start = time.process_time()
    base = common(run, eval_episodes, policy)
    extra: dict[str, Any] = {}
    if arm == "bc":
        # evaluated after 20 and 60 demonstrations; the 20-demonstration learner is the same
        # for every arm (same seeds, same supervisor data), so only BC evaluates it
        config = bc.BCConfig(
            **base, iterations=3, demos_per_iteration=PER_ITERATION, eval_at=(1, 3)
        )
        result = bc.run(config)
    elif arm == "dagger" or arm in RETRO_MODES:
        config = dagger.DAggerConfig(
            **base,
            iterations=K,
            demos_per_iteration=PER_ITERATION,
            beta=0.0,
            beta_schedule="constant",
            initial_demos=INITIAL,
            retrain_at=None,
            eval_at=(K,),
        )
        if arm == "dagger":
            result = dagger.run(config)
        else:
            result, measured = dagger_retroactive(config, RETRO_MODES[arm])
            extra["measured_label_correlation"] = measured
    else:
        config = dart.DARTConfig(
            **base,
            iterations=3,
            demos_per_iteration=PER_ITERATION,
            alpha=None,
            update_at=(1, 2),
            heldout_fraction=0.1,
            initial_noise_std=0.0,
            initial_epsilon=0.0,
            eval_at=(3,),
        )
        result = dart.run(config)
    records = result.evaluated()
    return {
        "run": run,
        "arm": arm,
        "demonstrations": [r.demonstrations for r in records],
        "labels": [r.labels_requested for r in records],
        "success": [r.eval_return for r in records],
        "supervisor_success": result.supervisor_return,
        "noise_trace": [r.extras.get("noise_level") for r in records],
        "cpu_seconds": round(time.process_time() - start, 1),
        **extra,
    }


def summarise(results: list[dict[str, Any]]) -> dict[str, Any]:
    summary: dict[str, Any] = {}
    for arm in (*ARMS, *ABLATIONS):
        rows = [r for r in results if r["arm"] == arm]
        if not rows:
            continue
        success = np.array([r["success"] for r in rows], dtype=float)
        entry = {
            "runs": len(rows),
            "demonstrations": rows[0]["demonstrations"],
            "mean": success.mean(axis=0).round(4).tolist(),
            "standard_error": (success.std(axis=0, ddof=1) / np.sqrt(len(rows))).round(4).tolist()
            if len(rows) > 1
            else None,
            "supervisor_success": round(float(np.mean([r["supervisor_success"] for r in rows])), 4),
        }
        if arm != "bc":
            # paired by run (the same 30 evaluation states): this arm minus BC, 60 demonstrations
            bc_final = {r["run"]: r["success"][-1] for r in results if r["arm"] == "bc"}
            diffs = [r["success"][-1] - bc_final[r["run"]] for r in rows if r["run"] in bc_final]
            if len(diffs) > 1:
                entry["minus_bc_at_60"] = {
                    "mean": round(float(np.mean(diffs)), 4),
                    "standard_error": round(float(np.std(diffs, ddof=1) / np.sqrt(len(diffs))), 4),
                    "runs": len(diffs),
                }
        if arm in RETRO_MODES:
            entry["measured_label_correlation"] = (
                np.mean([r["measured_label_correlation"] for r in rows], axis=0).round(3).tolist()
            )
        summary[arm] = entry
    return summary


def plot(summary: dict[str, Any], path: Path) -> None:
    """Success after 60 demonstrations per arm (bars, ± s.e.), and the shared 20-demonstration
    start (BC's first evaluation; every arm's first 20 demonstrations are the same)."""
    names = {
        "bc": "BC\n(off-policy)",
        "dart": "DART\n(off-policy)",
        "dagger": "DAgger\nclean labels",
        "dagger_retro": "DAgger\nretroactive\nlabel model",
        "dagger_shrink_only": "DAgger\nshrinkage\nonly",
        "dagger_noise_only": "DAgger\nnoise\nonly",
    }
    colours = {
        "bc": "tab:orange",
        "dart": "tab:green",
        "dagger": "tab:blue",
        "dagger_retro": "tab:purple",
        "dagger_shrink_only": "tab:gray",
        "dagger_noise_only": "tab:brown",
    }
    arms = [arm for arm in names if arm in summary]
    figure = new_figure(1, 1, (1.3 * len(arms) + 2.0, 4.2))
    axes = figure.axes[0]
    for k, arm in enumerate(arms):
        curve = summary[arm]
        error = (curve["standard_error"] or [0.0])[-1]
        axes.bar(k, curve["mean"][-1], yerr=error, color=colours[arm], capsize=4)
        axes.text(k, 0.02, f"{curve['runs']} runs", ha="center", fontsize=8, color="white")
    if "bc" in summary:
        start = summary["bc"]["mean"][0]
        axes.axhline(
            start, color="black", ls="--", lw=1, label=f"after the 20 shared demos: {start:.2f}"
        )
    axes.set_xticks(range(len(arms)), [names[a] for a in arms], fontsize=8)
    axes.set_ylabel("success on 30 held-out initial states")
    axes.set_title("Singulation-v0, Fig. 5.3 protocol: success after 60 demonstrations (± s.e.)")
    axes.set_ylim(0.0, 1.0)
    save_png_atomic(figure, path, legend_loc="upper right")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("out/reproduce_singulation"))
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--eval-episodes", type=int, default=30)
    parser.add_argument("--policy", choices=sorted(POLICIES), default="mlp")
    parser.add_argument("--arms", nargs="+", choices=(*ARMS, *ABLATIONS), default=list(ARMS))
    parser.add_argument("--workers", type=int, default=2, help="processes (1: run inline)")
    parser.add_argument(
        "--results",
        type=Path,
        default=None,
        help="the results file the docs read (default: docs/results/reproduce_singulation.json, "
        "or reproduce_singulation_<policy>_e<eval episodes>.json off the defaults)",
    )
    args = parser.parse_args()
    if min(args.runs, args.eval_episodes, args.workers) < 1:
        parser.error("--runs, --eval-episodes, --workers: >= 1")
    if args.results is None:
        suffix = (
            ""
            if (args.policy, args.eval_episodes) == ("mlp", 30)
            else f"_{args.policy}_e{args.eval_episodes}"
        )
        args.results = REPO / "docs" / "results" / f"reproduce_singulation{suffix}.json"

    runs_dir = args.out / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)
    tag = f"{args.policy}_e{args.eval_episodes}"
    jobs = [(run, arm) for run in range(args.runs) for arm in args.arms]
    path = {job: runs_dir / f"{tag}_{job[1]}_{job[0]}.json" for job in jobs}
    todo = [job for job in jobs if not path[job].exists()]
    expected = CPU_SECONDS_PER_RUN_ARM * len(todo) * args.eval_episodes / 30 / args.workers
    print(f"expected run time: ~{max(1, round(expected / 60))} min on {args.workers} free core(s)")
    machine_at_start = machine()
    bar = tqdm(total=len(jobs), initial=len(jobs) - len(todo), desc="runs x arms")

    def save(job: tuple[int, str], result: dict[str, Any]) -> None:
        write_json_atomic(path[job], result)
        bar.update(1)

    try:
        if args.workers == 1:
            for job in todo:
                save(job, run_arm(*job, args.eval_episodes, args.policy))
        else:
            with ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool:
                pending = {
                    pool.submit(run_arm, *job, args.eval_episodes, args.policy): job for job in todo
                }
                try:
                    while pending:
                        finished, _ = wait(pending, return_when=FIRST_COMPLETED)
                        for future in finished:
                            save(pending.pop(future), future.result())
                except KeyboardInterrupt:
                    for future in pending:
                        future.cancel()
                    raise
    except KeyboardInterrupt:
        bar.close()
        print(f"interrupted; finished results are kept in {runs_dir} (run again to resume)")
        return
    bar.close()

    # the summary covers every finished (run, arm) of this policy and evaluation size, including
    # those of earlier invocations (e.g. the ablations, run separately with fewer runs)
    results = [json.loads(f.read_text()) for f in sorted(runs_dir.glob(f"{tag}_*.json"))]
    results.sort(key=lambda r: ((*ARMS, *ABLATIONS).index(r["arm"]), r["run"]))
    summary = summarise(results)
    payload = {
        "figure": "dissertation Fig. 5.3 (on- vs off-policy, singulation)",
        "settings": {
            "runs_per_arm": {arm: c["runs"] for arm, c in summary.items()},
            "eval_episodes": args.eval_episodes,
            "policy": {
                "name": POLICIES[args.policy].name,
                "params": dict(POLICIES[args.policy].params),
            },
            "protocol": "20 supervisor demos, then 40 by each arm (DAgger: K = 2 iterations of 20)",
            "label_noise_targets": list(SOURCE_CORRELATIONS),
        },
        "cpu_seconds": round(sum(r["cpu_seconds"] for r in results), 1),
        "summary": summary,
        "results": results,
    }
    write_json_atomic(args.out / f"singulation_{tag}.json", payload)
    results_file = {
        "command": command_line(),
        "seeds": "run r uses seed r; arms share each run's seed",
    }
    results_file |= payload  # per-run results too: small, and the paired differences need them
    results_file["machine"] = machine_at_start
    args.results.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.results, results_file)
    plot(summary, args.out / f"singulation_fig5_3_{tag}.png")
    for arm, curve in summary.items():
        shown = ", ".join(
            f"{d} demos: {m:.3f}" + (f" ± {e:.3f}" if curve["standard_error"] else "")
            for d, m, e in zip(
                curve["demonstrations"],
                curve["mean"],
                curve["standard_error"] or [0.0] * len(curve["mean"]),
                strict=True,
            )
        )
        print(f"{arm:13s} {shown}  ({curve['runs']} runs)")
    print(f"wrote {args.out / f'singulation_{tag}.json'} and {args.results}")


if __name__ == "__main__":
    main()
