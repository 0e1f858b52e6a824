"""Supervisor quality table: success rate of fully supervised FLUIDS episodes, as JSON + Markdown.

For every scene of ``--cars`` × ``--peds`` on ``--layout``, runs ``--episodes`` seeded episodes in
which the supervisor drives every agent until all have arrived. An episode succeeds when every
agent reaches its goal with no collision; one that runs out of steps without a collision is a
deadlock. Usage: ``python scripts/quality/supervisor_quality.py --layout four_way --episodes 200``.
Several layouts may be given (the default is all three). With ``--results FILE`` (e.g.
``docs/results/fluids_supervisor_quality.json``) the report of every layout, the command and its
settings are written to FILE atomically; the docs' supervisor quality table reads it.

With ``--out FILE``, each scene's row is appended to ``FILE.jsonl`` as soon as it finishes, and a
rerun skips the scenes already there: a killed run resumes where it stopped.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed

from tqdm import tqdm

from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.jsonl import read_rows
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import relative_paths
from fluids_bench.tasks.fluids.sim.config import SceneConfig
from fluids_bench.tasks.fluids.supervisor.episode import run_supervised


def _scene_result(args: tuple[str, int, int, int, int]) -> dict:
    layout, cars, peds, episodes, max_steps = args
    scene = SceneConfig(layout=layout, num_cars=cars, num_pedestrians=peds)
    t0 = time.process_time()
    results = [run_supervised(scene, seed, max_steps=max_steps) for seed in range(episodes)]
    return {
        "layout": layout,
        "cars": cars,
        "pedestrians": peds,
        "episodes": episodes,
        "success": sum(r.success for r in results),
        "collision_episodes": sum(r.collisions > 0 for r in results),
        "deadlocks": sum(r.timed_out for r in results),
        "failed_seeds": [r.seed for r in results if not r.success],
        "steps": sum(r.steps for r in results),
        "cpu_seconds": round(time.process_time() - t0, 2),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--layout",
        nargs="+",
        default=["four_way", "t_junction", "roundabout"],
        choices=["four_way", "t_junction", "roundabout"],
    )
    parser.add_argument("--cars", type=int, nargs=2, default=(2, 7), metavar=("MIN", "MAX"))
    parser.add_argument("--peds", type=int, nargs=2, default=(0, 4), metavar=("MIN", "MAX"))
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument(
        "--max-steps", type=int, default=1500, help="steps before a deadlock is declared"
    )
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", default=None, help="JSON file to write (atomically)")
    parser.add_argument(
        "--results",
        default=None,
        help="results file for the docs (all layouts, the command and settings), written atomically",
    )
    args = parser.parse_args()
    scenes = (args.cars[1] - args.cars[0] + 1) * (args.peds[1] - args.peds[0] + 1)
    minutes = 0.0008 * scenes * args.episodes * len(args.layout) / max(1, min(args.workers, 2))
    print(f"expected run time: ~{max(1, round(minutes))} min on 2 cores", flush=True)
    started = time.time()
    reports = [_run_layout(args, layout) for layout in args.layout]
    if args.results:
        write_json_atomic(
            args.results,
            {
                "command": "python scripts/quality/supervisor_quality.py "
                + " ".join(shlex.quote(a) for a in relative_paths(sys.argv[1:])),
                "settings": {
                    "cars": list(args.cars),
                    "pedestrians": list(args.peds),
                    "episodes_per_scene": args.episodes,
                    "seeds": f"0..{args.episodes - 1} per scene",
                    "max_steps": args.max_steps,
                    "workers": args.workers,
                },
                "machine": {
                    "processor": platform.processor() or platform.machine(),
                    "cpu_count": os.cpu_count(),
                },
                "wall_seconds": round(time.time() - started, 1),
                "layouts": reports,
            },
        )


def _run_layout(args: argparse.Namespace, layout: str) -> dict:
    jobs = [
        (layout, c, p, args.episodes, args.max_steps)
        for c in range(args.cars[0], args.cars[1] + 1)
        for p in range(args.peds[0], args.peds[1] + 1)
    ]
    out = None
    if args.out:
        out = args.out if len(args.layout) == 1 else f"{args.out}.{layout}"
    log = f"{out}.jsonl" if out else None
    done = {(r["layout"], r["cars"], r["pedestrians"], r["episodes"]): r for r in read_rows(log)}
    todo = [j for j in jobs if j[:4] not in done]
    with ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool:
        futures = [pool.submit(_scene_result, job) for job in todo]
        for future in tqdm(as_completed(futures), total=len(futures), desc=layout, unit="scene"):
            row = future.result()
            done[(row["layout"], row["cars"], row["pedestrians"], row["episodes"])] = row
            if log:
                with open(log, "a") as f:
                    f.write(json.dumps(row) + "\n")
                    f.flush()
                    os.fsync(f.fileno())
    rows = [done[j[:4]] for j in jobs]
    total = sum(r["episodes"] for r in rows)
    report = {
        "layout": layout,
        "episodes": total,
        "collision_episodes": sum(r["collision_episodes"] for r in rows),
        "deadlocks": sum(r["deadlocks"] for r in rows),
        "success_rate": sum(r["success"] for r in rows) / total,
        "scenes": rows,
    }
    text = json.dumps(report, indent=2)
    if out:
        tmp = f"{out}.tmp"
        with open(tmp, "w") as f:
            f.write(text)
        os.replace(tmp, out)
    print(text)
    print(
        "\n| cars \\ peds | "
        + " | ".join(str(p) for p in range(args.peds[0], args.peds[1] + 1))
        + " |"
    )
    print("|---" * (args.peds[1] - args.peds[0] + 2) + "|")
    for c in range(args.cars[0], args.cars[1] + 1):
        cells = [f"{r['success']}/{r['episodes']}" for r in rows if r["cars"] == c]
        print(f"| {c} | " + " | ".join(cells) + " |")
    return report


if __name__ == "__main__":
    main()
