"""Supervisor quality table: success rate of fully supervised FLUIDS episodes, as JSON + Markdown.

For every scene of ``--cars`` × ``--peds`` on ``--layout``, runs ``--episodes`` seeded episodes in
which the supervisor drives every agent until all have arrived. An episode succeeds when every
agent reaches its goal with no collision; one that runs out of steps without a collision is a
deadlock. Usage: ``python scripts/quality/supervisor_quality.py --layout four_way --episodes 200``.

With ``--out FILE``, each scene's row is appended to ``FILE.jsonl`` as soon as it finishes, and a
rerun skips the scenes already there: a killed run resumes where it stopped.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed

from tqdm import tqdm

from fluids_bench.core.jsonl import read_rows
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
        "--layout", default="four_way", choices=["four_way", "t_junction", "roundabout"]
    )
    parser.add_argument("--cars", type=int, nargs=2, default=(2, 7), metavar=("MIN", "MAX"))
    parser.add_argument("--peds", type=int, nargs=2, default=(0, 4), metavar=("MIN", "MAX"))
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument(
        "--max-steps", type=int, default=1500, help="steps before a deadlock is declared"
    )
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", default=None, help="JSON file to write (atomically)")
    args = parser.parse_args()
    jobs = [
        (args.layout, c, p, args.episodes, args.max_steps)
        for c in range(args.cars[0], args.cars[1] + 1)
        for p in range(args.peds[0], args.peds[1] + 1)
    ]
    log = f"{args.out}.jsonl" if args.out else None
    done = {(r["layout"], r["cars"], r["pedestrians"], r["episodes"]): r for r in read_rows(log)}
    todo = [j for j in jobs if j[:4] not in done]
    with ProcessPoolExecutor(args.workers) as pool:
        futures = [pool.submit(_scene_result, job) for job in todo]
        for future in tqdm(
            as_completed(futures), total=len(futures), desc=args.layout, unit="scene"
        ):
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
        "layout": args.layout,
        "episodes": total,
        "success_rate": sum(r["success"] for r in rows) / total,
        "scenes": rows,
    }
    text = json.dumps(report, indent=2)
    if args.out:
        tmp = f"{args.out}.tmp"
        with open(tmp, "w") as f:
            f.write(text)
        os.replace(tmp, args.out)
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


if __name__ == "__main__":
    main()
