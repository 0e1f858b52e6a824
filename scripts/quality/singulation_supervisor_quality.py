"""The singulation supervisor's quality table: success over seeded episodes, with and without
Gaussian noise injected into the executed action (the DART setting).

For each noise level ``s`` in ``--noise`` (fractions of the action's half-range: 0.1 is the
issue's "10% noise") run ``--episodes`` episodes of Singulation-v0 (seeds 0, 1, ...; horizon
150 steps, the registration's) where the executed action is the supervisor's label plus
N(0, s² I), clipped to [-1, 1]. Reports success rate (with a 95% Wilson interval), steps to
success, final progress and behaviour-level replans per episode. Writes the results file the
docs read (``--results``, default ``docs/results/singulation_supervisor_quality.json``,
atomically, with the command line, seeds and settings) and prints a Markdown table. Batches of
25 episodes are saved under ``--out/parts`` as they finish, so an interrupted run resumes where
it stopped.

Usage: ``python scripts/quality/singulation_supervisor_quality.py --episodes 200 --workers 1``
(about 0.03 CPU-s per episode).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import fluids_bench  # noqa: F401
from fluids_bench.algos.actors import SUPERVISOR
from fluids_bench.algos.noise import isotropic_actor
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.algos.rollout import rollout
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import command_line, machine

ENV_ID = "Singulation-v0"
ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "docs" / "results" / "singulation_supervisor_quality.json"
CPU_SECONDS_PER_EPISODE = 0.03  # measured: supervisor-driven episodes of ~20 steps, one replan


def episodes(noise: float, seeds: list[int]) -> list[dict[str, Any]]:
    env = gym.make(ENV_ID)
    actor = SUPERVISOR if noise == 0 else isotropic_actor(env.action_space, noise, 0.0)
    out = []
    for seed in seeds:
        t = rollout(env, actor, seed)
        last = t.infos[-1]
        out.append(
            {
                "seed": seed,
                "success": bool(last["is_success"]),
                "steps": len(t),
                "progress": float(last["progress"]),
                "replans": env.unwrapped.supervisor_stats()["replans"],
                "replan_s": env.unwrapped.supervisor_stats()["replan_seconds"],
            }
        )
    env.close()
    return out


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--noise", type=float, nargs="+", default=[0.0, 0.1, 0.2, 0.5])
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("out/singulation_quality"))
    parser.add_argument(
        "--results", type=Path, default=RESULTS, help="the results file the docs read (JSON)"
    )
    args = parser.parse_args()
    if args.episodes < 1 or args.workers < 1 or min(args.noise) < 0:
        parser.error("--episodes and --workers >= 1, --noise >= 0")

    expected = CPU_SECONDS_PER_EPISODE * args.episodes * len(args.noise) / args.workers
    print(f"expected run time: ~{max(1, round(expected / 60))} min on {args.workers} free core(s)")
    machine_at_start = machine()
    start = time.perf_counter()
    # batches of 25 seeds, each saved as it finishes: a rerun skips the finished ones
    parts = args.out / "parts"
    parts.mkdir(parents=True, exist_ok=True)
    chunks = [list(range(k, min(k + 25, args.episodes))) for k in range(0, args.episodes, 25)]
    jobs = [(noise, chunk) for noise in args.noise for chunk in chunks]

    def part(noise: float, chunk: list[int]) -> Path:
        return parts / f"noise{noise:g}_seeds{chunk[0]}-{chunk[-1]}.json"

    todo = [job for job in jobs if not part(*job).exists()]
    bar = tqdm(total=len(jobs), initial=len(jobs) - len(todo), desc="batches of 25 episodes")
    if args.workers == 1:
        for job in todo:
            write_json_atomic(part(*job), episodes(*job))
            bar.update(1)
    else:
        with ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool:
            futures = {pool.submit(episodes, *job): job for job in todo}
            for future in as_completed(futures):
                write_json_atomic(part(*futures[future]), future.result())
                bar.update(1)
    bar.close()
    rows = {
        noise: [e for chunk in chunks for e in json.loads(part(noise, chunk).read_text())]
        for noise in args.noise
    }

    table = []
    for noise in args.noise:
        eps = sorted(rows[noise], key=lambda e: e["seed"])
        wins = sum(e["success"] for e in eps)
        lo, hi = wilson(wins, len(eps))
        replans = sum(e["replans"] for e in eps)
        table.append(
            {
                "noise_std": noise,
                "episodes": len(eps),
                "success_rate": wins / len(eps),
                "wilson95": [round(lo, 4), round(hi, 4)],
                "mean_steps_to_success": (
                    round(float(np.mean([e["steps"] for e in eps if e["success"]])), 2)
                    if wins
                    else None
                ),
                "mean_final_progress_m": round(float(np.mean([e["progress"] for e in eps])), 4),
                "replans_per_episode": round(replans / len(eps), 2),
                "replan_ms_mean": round(1e3 * sum(e["replan_s"] for e in eps) / max(replans, 1), 2),
                "failed_seeds": [e["seed"] for e in eps if not e["success"]],
            }
        )
    args.out.mkdir(parents=True, exist_ok=True)
    report = {
        "command": command_line(),
        "env": ENV_ID,
        "seeds": f"0-{args.episodes - 1}",
        "episodes": args.episodes,
        "horizon": gym.spec(ENV_ID).max_episode_steps,
        "noise_levels": args.noise,
        "noise": "executed = clip(label + N(0, s^2 I), -1, 1), s in normalised action units",
        "workers": args.workers,
        "machine": machine_at_start,
        "seconds": round(time.perf_counter() - start, 1),
        "table": table,
    }
    write_json_atomic(args.out / "singulation_supervisor_quality.json", report)
    args.results.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.results, report)
    print(f"wrote {args.results}")
    print(
        "| action noise (std) | episodes | success | 95% interval | steps to success | replans / episode |"
    )
    print("|---|---|---|---|---|---|")
    for r in table:
        print(
            f"| {r['noise_std']:.2f} | {r['episodes']} | {100 * r['success_rate']:.1f}% | "
            f"{100 * r['wilson95'][0]:.1f}–{100 * r['wilson95'][1]:.1f}% | "
            f"{r['mean_steps_to_success']} | {r['replans_per_episode']} |"
        )


if __name__ == "__main__":
    main()
