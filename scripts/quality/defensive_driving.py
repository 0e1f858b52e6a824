"""Do supervised drivers cause collisions with an ego that does not follow the supervisor?

For every layout, scene (``--cars`` cars in all, the ego included, × ``--peds`` pedestrians)
and ego policy, runs ``--episodes`` seeded episodes at the velocity level and counts the
collisions by who was at fault (``info["collisions"][i]["at_fault"]``, see
:mod:`fluids_bench.tasks.fluids.sim.fault`). Ego policies:

* ``supervisor``: the supervisor's own label (the ego drives as the others do);
* ``stop``: follows the supervisor, then from a random step in [0, 100) asks for 0 m/s;
* ``crawl``: 1 m/s throughout;
* ``random``: a uniform target speed in [0, v_max] every step;
* ``noisy``: the supervisor's label plus N(0, 2²) m/s noise, clipped.

``--defensive`` compares both planners (v0's: off; v1's: on); ``--yield-to-pedestrians`` makes
the defensive arm v1's whole planner (cars also wait for walkers on crosswalks). An episode runs until the ego
arrives or collides, or 400 steps; scene (c cars, p pedestrians) uses seeds 1000c + 100p + i. Rows append to ``--out``.jsonl as they finish and a rerun
skips them (resumable); the summary is written atomically to ``--out``, and with ``--results
FILE`` also to FILE with the command and its settings (the docs' tables read
``docs/results/defensive_driving_v1.json`` and ``docs/results/defensive_driving_v0_v1.json``).

    python scripts/quality/defensive_driving.py --episodes 200 --workers 2 --out defensive.json
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.jsonl import read_rows
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import announce, relative_paths

POLICIES = ("supervisor", "stop", "crawl", "random", "noisy")
LAYOUTS = ("four_way", "t_junction", "roundabout")


def _ego_action(policy: str, info: dict, rng: np.random.Generator, step: int, stop_at: int):
    vmax = 10.0
    if policy == "supervisor":
        return info["supervisor_action"]
    if policy == "stop":
        return info["supervisor_action"] if step < stop_at else np.zeros(1, np.float32)
    if policy == "crawl":
        return np.ones(1, np.float32)
    if policy == "random":
        return rng.uniform(0.0, vmax, 1).astype(np.float32)
    label = info["supervisor_action"]
    return np.clip(label + rng.normal(0.0, 2.0, 1), 0.0, vmax).astype(np.float32)


def run_episode(
    layout: str, cars: int, peds: int, policy: str, defensive: bool, yields: bool, seed: int
):
    env = gym.make(
        "FLUIDS-v0",
        layout=layout,
        num_cars=cars - 1,
        num_pedestrians=peds,
        action_level="velocity",
        defensive=defensive,
        yield_to_pedestrians=yields,
    )
    rng = np.random.default_rng([seed, POLICIES.index(policy)])
    stop_at = int(rng.integers(0, 100))
    obs, info = env.reset(seed=seed)
    out = {"supervised": 0, "cut_in": 0, "ego": 0, "other": 0, "arrived": False}
    for step in range(400):
        obs, r, term, trunc, info = env.step(_ego_action(policy, info, rng, step, stop_at))
        for c in info["collisions"]:
            fault = c["at_fault"]
            if c["cut_in"]:
                out["cut_in"] += 1
            elif any(i != 0 for i in fault):
                out["supervised"] += 1
            elif 0 in fault:
                out["ego"] += 1
            else:
                out["other"] += 1
        if term or trunc:
            break
    out["arrived"] = bool(info["ego_arrived"])
    env.close()
    return out


def scene_row(job: tuple) -> dict:
    layout, cars, peds, policy, defensive, episodes, yields = job
    t0 = time.process_time()
    # distinct seeds per scene (a scene's first seed is 1000 · cars + 100 · pedestrians), so
    # scenes that differ only in walkers do not replay the same cars
    base = 1000 * cars + 100 * peds
    rows = [
        run_episode(layout, cars, peds, policy, defensive, yields, base + s)
        for s in range(episodes)
    ]
    return {
        "layout": layout,
        "cars": cars,
        "pedestrians": peds,
        "policy": policy,
        "defensive": defensive,
        "episodes": episodes,
        "yield_to_pedestrians": yields,
        "supervised_fault": sum(r["supervised"] for r in rows),
        "cut_in": sum(r["cut_in"] for r in rows),
        "ego_fault": sum(r["ego"] for r in rows),
        "supervised_fault_episodes": sum(r["supervised"] > 0 for r in rows),
        "arrived": sum(r["arrived"] for r in rows),
        "cpu_seconds": round(time.process_time() - t0, 2),
    }


def _key(job) -> tuple:
    """A job's identity: (layout, cars, pedestrians, policy, defensive, episodes, yields)."""
    return tuple(job)


def _row_key(row: dict) -> tuple:
    """The identity of a finished row of the log, as :func:`_key` of its job."""
    fields = ("layout", "cars", "pedestrians", "policy", "defensive", "episodes")
    return (*(row[f] for f in fields), row.get("yield_to_pedestrians", False))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--layouts", nargs="+", default=list(LAYOUTS), choices=LAYOUTS)
    parser.add_argument("--cars", type=int, nargs=2, default=(2, 7), metavar=("MIN", "MAX"))
    parser.add_argument("--peds", type=int, nargs=2, default=(0, 4), metavar=("MIN", "MAX"))
    parser.add_argument("--policies", nargs="+", default=list(POLICIES), choices=POLICIES)
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--defensive", choices=["on", "off", "both"], default="both")
    parser.add_argument(
        "--yield-to-pedestrians",
        action="store_true",
        help="the defensive arm also yields to walkers on crosswalks (v1's planner)",
    )
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", default=None, help="JSON summary (rows also in OUT.jsonl)")
    parser.add_argument(
        "--results", default=None, help="also write the summary, command and settings to this file"
    )
    args = parser.parse_args()
    announce(
        "~0.2 CPU-s per episode: --episodes 20 (9,000 episodes) ~30 min on one core, --episodes 200 hours"
    )
    modes = {"on": [True], "off": [False], "both": [False, True]}[args.defensive]
    jobs = [
        (layout, c, p, pol, d, args.episodes, d and args.yield_to_pedestrians)
        for layout in args.layouts
        for pol in args.policies
        for d in modes
        for c in range(args.cars[0], args.cars[1] + 1)
        for p in range(args.peds[0], args.peds[1] + 1)
    ]
    log = f"{args.out}.jsonl" if args.out else None
    done = {_row_key(row): row for row in read_rows(log)}
    todo = [j for j in jobs if _key(j) not in done]
    with ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool:
        futures = [pool.submit(scene_row, j) for j in todo]
        for fut in tqdm(as_completed(futures), total=len(futures), unit="scene"):
            row = fut.result()
            done[_row_key(row)] = row
            if log:
                with open(log, "a") as f:
                    f.write(json.dumps(row) + "\n")
    rows = [done[_key(j)] for j in jobs]
    summary = {}
    for r in rows:
        mode = "v0"
        if r["defensive"]:
            mode = "v1" if r.get("yield_to_pedestrians") else "defensive"
        k = f"{r['layout']}/{r['policy']}/{mode}"
        s = summary.setdefault(
            k,
            {
                "episodes": 0,
                "supervised_fault": 0,
                "supervised_fault_episodes": 0,
                "cut_in": 0,
                "ego_fault": 0,
                "arrived": 0,
            },
        )
        for f in s:
            s[f] += r[f]
    text = json.dumps({"summary": summary, "scenes": rows}, indent=1)
    if args.results:
        write_json_atomic(
            args.results,
            {
                "command": "python scripts/quality/defensive_driving.py "
                + " ".join(shlex.quote(a) for a in relative_paths(sys.argv[1:])),
                "settings": {
                    "layouts": args.layouts,
                    "cars": list(args.cars),
                    "pedestrians": list(args.peds),
                    "policies": args.policies,
                    "episodes_per_scene": args.episodes,
                    "seeds": "1000*cars + 100*pedestrians + i, i < episodes",
                    "planners": args.defensive,
                    "yield_to_pedestrians": args.yield_to_pedestrians,
                },
                "summary": summary,
                "scenes": rows,
            },
        )
    if args.out:
        with open(f"{args.out}.tmp", "w") as f:
            f.write(text)
        os.replace(f"{args.out}.tmp", args.out)
    print(
        "| layout | ego policy | planner | episodes | supervised at fault | cut-ins | ego at "
        "fault | ego arrived |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for k, s in summary.items():
        layout, pol, mode = k.split("/")
        print(
            f"| {layout} | {pol} | {mode} | {s['episodes']} | {s['supervised_fault']} "
            f"({s['supervised_fault_episodes']} ep.) | {s['cut_in']} | {s['ego_fault']} | "
            f"{s['arrived']} |"
        )


if __name__ == "__main__":
    main()
