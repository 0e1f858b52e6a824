"""Supervisor quality on GraspingInClutter-v0: success and the source's cost over seeded episodes.

Runs ``--episodes`` episodes (seeds 0, 1, ...) with the supervisor acting, once as is and once
with Gaussian noise injected into the executed action (``--noise``, default 0.1: a standard
deviation of 10% of the velocity command's full scale on every action dimension, clipped to the
action box; the DART setting). Horizon: the registration's 100 steps of 0.1 s. Reports success
(grasped, nothing knocked off), mean cost (knocked off + 10 × not grasped), grasps, knocked-off
objects, steps, replans and CPU time per step, as JSON and a Markdown table.

Resumable: every finished episode is appended to ``<out>/grasping_quality.jsonl``; a rerun
skips those. Writes the results file the docs read (``--results``, default
``docs/results/grasping_supervisor_quality.json``, atomically, with the command line, seeds and
settings). Usage: ``python scripts/quality/grasping_supervisor_quality.py --episodes 200 --workers 1``
(about 0.35 CPU-s per episode). Needs the package importable (``pip install -e .`` or ``PYTHONPATH=.``).
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.jsonl import read_rows
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import command_line, machine

ENV_ID = "GraspingInClutter-v0"
ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "docs" / "results" / "grasping_supervisor_quality.json"
CPU_SECONDS_PER_EPISODE = 0.35  # measured: supervisor-driven episodes of ~25 steps


def episode(job: tuple[float, int]) -> dict:
    """One supervised episode with ``noise`` injected into the executed action."""
    noise, seed = job
    env = gym.make(ENV_ID)
    rng = np.random.default_rng([seed, 0x5EED])  # the noise stream, apart from the env's
    start = time.process_time()
    _, info = env.reset(seed=seed)
    steps, done = 0, False
    while not done:
        action = info["supervisor_action"]
        if noise > 0:
            action = action + noise * rng.standard_normal(3).astype(np.float32)
            action = np.clip(action, env.action_space.low, env.action_space.high)
        _, _, terminated, truncated, info = env.step(action)
        steps += 1
        done = terminated or truncated
    sup = env.unwrapped.supervisor
    return {
        "noise": noise,
        "seed": seed,
        "success": bool(info["is_success"]),
        "cost": float(info["cost"]),
        "grasped": bool(info["grasped"]),
        "knocked_off": int(info["knocked_off"]),
        "steps": steps,
        "replans": sup.replans,
        "replan_seconds": sup.replan_seconds,
        "cpu_seconds": time.process_time() - start,
    }


def summary(rows: list[dict]) -> dict:
    n = len(rows)
    cost = np.array([r["cost"] for r in rows])
    success = np.array([r["success"] for r in rows], dtype=float)
    steps = sum(r["steps"] for r in rows)
    return {
        "episodes": n,
        "success_rate": float(success.mean()),
        "success_stderr": float(success.std(ddof=1) / np.sqrt(n)) if n > 1 else 0.0,
        "mean_cost": float(cost.mean()),
        "cost_stderr": float(cost.std(ddof=1) / np.sqrt(n)) if n > 1 else 0.0,
        "grasp_rate": float(np.mean([r["grasped"] for r in rows])),
        "mean_knocked_off": float(np.mean([r["knocked_off"] for r in rows])),
        "mean_steps": steps / n,
        "mean_replans": float(np.mean([r["replans"] for r in rows])),
        "ms_per_replan": 1e3
        * sum(r["replan_seconds"] for r in rows)
        / max(1, sum(r["replans"] for r in rows)),
        "cpu_steps_per_second": steps / sum(r["cpu_seconds"] for r in rows),
        "failed_seeds": [r["seed"] for r in rows if not r["success"]],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--noise", type=float, default=0.1, help="std of the injected noise")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", default="out/grasping_quality", help="output folder")
    parser.add_argument(
        "--results", type=Path, default=RESULTS, help="the results file the docs read (JSON)"
    )
    args = parser.parse_args()
    if args.episodes < 1 or args.workers < 1 or args.noise < 0:
        parser.error("--episodes and --workers >= 1, --noise >= 0")
    expected = CPU_SECONDS_PER_EPISODE * 2 * args.episodes / args.workers
    print(f"expected run time: ~{max(1, round(expected / 60))} min on {args.workers} free core(s)")
    machine_at_start = machine()
    start = time.perf_counter()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    log = out / "grasping_quality.jsonl"
    done = {(row["noise"], row["seed"]): row for row in read_rows(log)}
    levels = (0.0, args.noise)
    jobs = [(noise, seed) for noise in levels for seed in range(args.episodes)]
    todo = [job for job in jobs if job not in done]
    with (
        ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool,
        open(log, "a") as f,
    ):
        futures = [pool.submit(episode, job) for job in todo]
        for future in tqdm(as_completed(futures), total=len(futures), unit="episode"):
            row = future.result()
            done[(row["noise"], row["seed"])] = row
            f.write(json.dumps(row) + "\n")
            f.flush()
    report = {
        "command": command_line(),
        "env": ENV_ID,
        "seeds": f"0-{args.episodes - 1}",
        "episodes": args.episodes,
        "horizon_steps": gym.spec(ENV_ID).max_episode_steps,
        "noise_std": args.noise,
        "noise": "executed = clip(label + N(0, s^2 I), low, high) on every action dimension",
        "workers": args.workers,
        "machine": machine_at_start,
        "seconds": round(time.perf_counter() - start, 1),
        "results": {
            str(noise): summary([done[(noise, s)] for s in range(args.episodes)])
            for noise in levels
        },
    }
    write_json_atomic(out / "grasping_quality.json", report)
    args.results.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.results, report)
    print(f"wrote {args.results}")
    print("\n| executed action | episodes | success | mean cost | grasped | knocked off / ep. |")
    print("|---|---|---|---|---|---|")
    for noise in levels:
        r = report["results"][str(noise)]
        label = "supervisor" if noise == 0 else f"supervisor + N(0, {noise}²) noise"
        print(
            f"| {label} | {r['episodes']} | {r['success_rate']:.1%} ± {r['success_stderr']:.1%} "
            f"| {r['mean_cost']:.2f} ± {r['cost_stderr']:.2f} | {r['grasp_rate']:.1%} "
            f"| {r['mean_knocked_off']:.2f} |"
        )


if __name__ == "__main__":
    main()
