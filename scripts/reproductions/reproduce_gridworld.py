"""Reproduce the source's Fig. 3.1: on- vs off-policy on random gridworlds, two policy classes.

For each of ``--worlds`` random GridWorld-v0 worlds (``world_seed`` 0, 1, ...) run

- off-policy: Behavior Cloning, one supervisor demonstration per iteration;
- on-policy: DAgger (beta = 0) after one initial supervisor demonstration (as in the source),

with a low-expressiveness class (linear SVM) and a high-expressiveness one (decision tree of
depth 100), and record normalised performance (1.0 = the value-iteration supervisor's return
on the same evaluation seeds) against the amount of data (demonstrations, 30 state–label pairs
each). Worlds where the supervisor's mean return is not positive have no normalised value and
are left out of the means (their count is reported).

The source's settings are written out in :data:`ON_POLICY` and :data:`OFF_POLICY` (not left to
the library's defaults) and printed at the start. Each world's curves are saved to
``--out/worlds/world_NNN.json`` as soon as they are done, so an interrupted run resumes where it
stopped. Writes ``gridworld.json`` (settings, per-world curves, means and standard errors) and
``gridworld.png`` to ``--out``, and the results file the docs read (``--results``, default
``docs/results/reproduce_gridworld.json``: the command line, settings and the curves' means and
standard errors; the per-world curves stay in ``--out``). About 0.9 CPU-s per world.
Quick run: ``python scripts/reproductions/reproduce_gridworld.py --worlds 5 --results out/gw.json``.
Needs the package importable (``pip install -e .`` or ``PYTHONPATH=.``).
"""

from __future__ import annotations

import argparse
import json
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

REPO = Path(__file__).resolve().parents[2]
RESULTS = REPO / "docs" / "results" / "reproduce_gridworld.json"
CPU_SECONDS_PER_WORLD = 0.9  # measured: both classes, both methods, 20 iterations


CLASSES = {
    "linear_svm": PolicySpec("linear_svm"),
    "tree_depth_100": PolicySpec("tree", {"max_depth": 100}),
}
METHODS = ("off_policy_bc", "on_policy_dagger")
# the source's protocol for Fig. 3.1, stated here rather than inherited from library defaults:
# T = 30 steps, so every visited state of a demonstration is a training pair (no subsampling)
OFF_POLICY: dict[str, Any] = {"samples_per_demo": None, "demos_per_iteration": 1}
ON_POLICY: dict[str, Any] = {
    **OFF_POLICY,
    "initial_demos": 1,  # one initial supervisor demonstration
    "beta": 0.0,  # pure on-policy: the learner acts in every step after the first demonstration
    "beta_schedule": "constant",
    "retrain_at": None,  # DAgger: refit after every iteration
}


def run_world(world: int, iterations: int, eval_episodes: int, eval_every: int) -> dict[str, Any]:
    """All four curves of one world: normalised performance per number of demonstrations."""
    curves: dict[str, Any] = {}
    # DAgger's iteration k has k + 1 demonstrations (one initial), BC's iteration k has k:
    # evaluate both at the same numbers of demonstrations
    on_eval = tuple(range(0, iterations + 1, eval_every))
    off_eval = tuple(k + 1 for k in on_eval)
    for class_name, spec in CLASSES.items():
        common = {
            "env_id": "GridWorld-v0",
            "env_kwargs": {"world_seed": world},
            "policy": spec,
            "eval_episodes": eval_episodes,
            "seed": world,
        }
        off = bc.run(
            bc.BCConfig(**common, **OFF_POLICY, iterations=iterations + 1, eval_at=off_eval)
        )
        on = dagger.run(
            dagger.DAggerConfig(**common, **ON_POLICY, iterations=iterations, eval_at=on_eval)
        )
        for method, result in zip(METHODS, (off, on), strict=True):
            records = result.evaluated()
            curves[f"{class_name}/{method}"] = {
                "demonstrations": [r.demonstrations for r in records],
                "labels": [r.training_labels for r in records],
                "normalised": [r.normalised_performance for r in records],
                "supervisor_return": result.supervisor_return,
            }
    return {"world": world, "curves": curves}


def run_world_cached(folder: Path, world: int, *settings: int) -> dict[str, Any]:
    """:func:`run_world`, or its saved result when an earlier run with the same settings did it."""
    path = folder / f"world_{world:03d}.json"
    if path.exists():
        saved = json.loads(path.read_text())
        if saved.get("settings") == list(settings):
            return saved["result"]
    result = run_world(world, *settings)
    write_json_atomic(path, {"settings": list(settings), "result": result})
    return result


def summarise(worlds: list[dict[str, Any]]) -> dict[str, Any]:
    """Mean and standard error across worlds, per curve and number of demonstrations."""
    summary: dict[str, Any] = {}
    for key in worlds[0]["curves"]:
        rows = [w["curves"][key]["normalised"] for w in worlds]
        usable = np.array([r for r in rows if None not in r], dtype=float)
        summary[key] = {
            "demonstrations": worlds[0]["curves"][key]["demonstrations"],
            "labels": worlds[0]["curves"][key]["labels"],
            "mean": usable.mean(axis=0).round(4).tolist(),
            "standard_error": (usable.std(axis=0, ddof=1) / np.sqrt(len(usable))).round(4).tolist()
            if len(usable) > 1
            else None,
            "worlds_used": len(usable),
            "worlds_without_normalisation": len(rows) - len(usable),
        }
    return summary


def plot(summary: dict[str, Any], path: Path, n_worlds: int) -> None:
    figure = new_figure(1, 2, (11.0, 4.2))
    titles = {"linear_svm": "(a) linear SVM", "tree_depth_100": "(b) decision tree, depth 100"}
    for axes, class_name in zip(figure.axes, CLASSES, strict=True):
        for method, colour in zip(METHODS, ("tab:orange", "tab:blue"), strict=True):
            curve = summary[f"{class_name}/{method}"]
            x, mean = np.array(curve["labels"]), np.array(curve["mean"])
            error = np.array(curve["standard_error"] or np.zeros_like(mean))
            label = "off-policy (BC)" if method.startswith("off") else "on-policy (DAgger)"
            axes.plot(x, mean, color=colour, label=label)
            axes.fill_between(x, mean - error, mean + error, color=colour, alpha=0.2)
        axes.axhline(1.0, color="black", ls="--", lw=1, label="supervisor")
        axes.set_title(f"{titles[class_name]}, {n_worlds} worlds")
        axes.set_xlabel("state–label pairs (30 per demonstration)")
        axes.set_ylabel("normalised performance")
    save_png_atomic(figure, path, legend_loc="lower right")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("out/reproduce_gridworld"))
    parser.add_argument("--worlds", type=int, default=100, help="number of random worlds")
    parser.add_argument("--iterations", type=int, default=20, help="on-policy iterations")
    parser.add_argument("--eval-episodes", type=int, default=20)
    parser.add_argument("--eval-every", type=int, default=2, help="evaluate every k iterations")
    parser.add_argument("--workers", type=int, default=2, help="processes (1: run inline)")
    parser.add_argument(
        "--results", type=Path, default=RESULTS, help="the results file the docs read (JSON)"
    )
    args = parser.parse_args()
    if min(args.worlds, args.iterations, args.eval_episodes, args.eval_every, args.workers) < 1:
        parser.error("--worlds, --iterations, --eval-episodes, --eval-every, --workers: >= 1")
    expected = CPU_SECONDS_PER_WORLD * args.worlds * args.iterations / 20 / args.workers
    print(f"expected run time: ~{max(1, round(expected / 60))} min on {args.workers} free core(s)")
    machine_at_start = machine()

    print(f"off-policy (BC): {OFF_POLICY}")
    print(f"on-policy (DAgger): {ON_POLICY}")
    print(f"policies: { {k: (v.name, dict(v.params)) for k, v in CLASSES.items()} }")
    start = time.perf_counter()
    folder = args.out / "worlds"
    settings = (args.iterations, args.eval_episodes, args.eval_every)
    jobs = [(folder, w, *settings) for w in range(args.worlds)]
    if args.workers == 1:
        worlds = [run_world_cached(*job) for job in tqdm(jobs, desc="worlds")]
    else:
        with ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool:
            futures = [pool.submit(run_world_cached, *job) for job in jobs]
            worlds = [f.result() for f in tqdm(futures, desc="worlds")]
    summary = summarise(worlds)
    seconds = time.perf_counter() - start

    args.out.mkdir(parents=True, exist_ok=True)
    payload = {
        "figure": "dissertation Fig. 3.1 (on- vs off-policy, gridworld)",
        "settings": {
            "worlds": args.worlds,
            "iterations": args.iterations,
            "eval_episodes": args.eval_episodes,
            "eval_every": args.eval_every,
            "env": "GridWorld-v0 (15x15, 8% penalties, slip 0.16, T = 30)",
            "on_policy": {"algorithm": "DAgger", **ON_POLICY},
            "off_policy": {"algorithm": "Behavior Cloning", **OFF_POLICY},
        },
        "seconds": round(seconds, 1),
        "summary": summary,
        "worlds": worlds,
    }
    write_json_atomic(args.out / "gridworld.json", payload)
    results = {"command": command_line(), "seeds": f"world_seed 0-{args.worlds - 1}"}
    results |= {k: v for k, v in payload.items() if k != "worlds"}
    results |= {"workers": args.workers, "machine": machine_at_start}
    args.results.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.results, results)
    plot(summary, args.out / "gridworld.png", args.worlds)
    for key, curve in summary.items():
        picks = sorted(
            {0, len(curve["mean"]) // 4, len(curve["mean"]) // 2, len(curve["mean"]) - 1}
        )
        shown = ", ".join(
            f"{curve['demonstrations'][i]} demos: {curve['mean'][i]:.3f}" for i in picks
        )
        print(f"{key:34s} {shown}  ({curve['worlds_used']} worlds)")
    print(f"{seconds:.0f} s; wrote {args.out / 'gridworld.json'}, {args.out / 'gridworld.png'}")
    print(f"wrote {args.results}")


if __name__ == "__main__":
    main()
