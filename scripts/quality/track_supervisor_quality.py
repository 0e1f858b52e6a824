"""DrivingTrack supervisor quality: crashes per lap of the search supervisor by look-ahead depth,
with and without action noise, over many seeded tracks; JSON lines + a Markdown table.

For every depth in ``--depths`` and noise level in ``--noise``, the supervisor drives one
two-lap episode on each of ``--tracks`` tracks (``track_seed`` 0, 1, ...; episode seed = track
seed). With noise ``p``, each step executes one of the two other actions, uniformly, with
probability ``p`` (the label stays the supervisor's), from a generator seeded by the track.
Reported: crashes per lap (total crashes / total laps), the share of laps completed without a
crash, the share of episodes that crashed at all, and the mean label time.

Resumable: each finished (depth, noise) row is appended to ``--out`` (JSON lines) and skipped
on a rerun. Writes the results file the docs read (``--results``, default
``docs/results/track_supervisor_quality.json``, atomically, with the command line, seeds and
settings). Usage: ``python scripts/quality/track_supervisor_quality.py --tracks 200 --workers 1``
(about 0.05 CPU-s per two-lap episode with the state observation).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import fluids_bench  # noqa: F401
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import command_line, machine
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "docs" / "results" / "track_supervisor_quality.json"
CPU_SECONDS_PER_EPISODE = 0.05  # measured: two laps (~180 steps) at depth 8, state observation


def run_row(depth: int, noise: float, tracks: int) -> dict:
    crashes = laps = clean_laps = crashed_episodes = steps = 0
    t0 = time.process_time()
    for seed in range(tracks):
        env = gym.make("DrivingTrack-v0", obs_type="state", depth=depth, track_seed=seed)
        rng = np.random.default_rng([seed, 0x5EED])
        _, info = env.reset(seed=seed)
        done, lap_crashes, last_lap = False, [], 0
        while not done:
            action = int(info[SUPERVISOR_ACTION_KEY])
            if rng.random() < noise:
                action = (action + int(rng.integers(1, 3))) % 3
            _, _, terminated, truncated, info = env.step(action)
            steps += 1
            done = terminated or truncated
            if int(info["laps"]) > last_lap:  # a lap just completed
                lap_crashes.append(info["crashes"] - sum(lap_crashes))
                last_lap = int(info["laps"])
        crashes += info["crashes"]
        laps += info["laps"]
        clean_laps += sum(c == 0 for c in lap_crashes)
        crashed_episodes += info["crashes"] > 0
    return {
        "depth": depth,
        "noise": noise,
        "tracks": tracks,
        "crashes_per_lap": round(crashes / laps, 3),
        "clean_lap_share": round(clean_laps / (2 * tracks), 3),
        "episodes_with_a_crash": round(crashed_episodes / tracks, 3),
        "steps": steps,
        "cpu_us_per_step": round((time.process_time() - t0) / steps * 1e6, 1),
    }


def table(rows: list[dict]) -> str:
    noises = sorted({r["noise"] for r in rows})
    head = "| depth | " + " | ".join(f"crashes/lap, noise {n:g}" for n in noises)
    head += " | " + " | ".join(f"clean laps, noise {n:g}" for n in noises) + " |"
    lines = [head, "|" + "---|" * (1 + 2 * len(noises))]
    by = {(r["depth"], r["noise"]): r for r in rows}
    for depth in sorted({r["depth"] for r in rows}):
        cells = [
            f"{by[depth, n]['crashes_per_lap']:.2f}" if (depth, n) in by else "" for n in noises
        ]
        cells += [
            f"{by[depth, n]['clean_lap_share']:.0%}" if (depth, n) in by else "" for n in noises
        ]
        lines.append(f"| {depth} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--depths", type=int, nargs="+", default=[1, 2, 3, 4, 6, 8, 10])
    parser.add_argument("--noise", type=float, nargs="+", default=[0.0, 0.1])
    parser.add_argument("--tracks", type=int, default=200)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("out/track_supervisor_quality.jsonl"))
    parser.add_argument(
        "--results", type=Path, default=RESULTS, help="the results file the docs read (JSON)"
    )
    args = parser.parse_args()
    if args.tracks < 1 or args.workers < 1 or min(args.noise) < 0 or min(args.depths) < 1:
        parser.error("--tracks, --workers and --depths >= 1, --noise >= 0")
    expected = CPU_SECONDS_PER_EPISODE * args.tracks * len(args.depths) * len(args.noise)
    expected /= args.workers
    print(f"expected run time: ~{max(1, round(expected / 60))} min on {args.workers} free core(s)")
    machine_at_start = machine()
    start = time.perf_counter()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    done = []
    if args.out.exists():
        done = [json.loads(line) for line in args.out.read_text().splitlines() if line]
        done = [r for r in done if r["tracks"] == args.tracks]
    todo = [
        (d, n)
        for d in args.depths
        for n in args.noise
        if not any(r["depth"] == d and r["noise"] == n for r in done)
    ]
    with (
        ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool,
        open(args.out, "a") as sink,
    ):
        futures = [pool.submit(run_row, d, n, args.tracks) for d, n in todo]
        for future in tqdm(as_completed(futures), total=len(futures), desc="rows"):
            row = future.result()
            sink.write(json.dumps(row) + "\n")  # one whole line per finished row
            sink.flush()
            os.fsync(sink.fileno())
            done.append(row)
    rows = sorted(
        (r for r in done if r["depth"] in args.depths and r["noise"] in args.noise),
        key=lambda r: (r["depth"], r["noise"]),
    )
    report = {
        "command": command_line(),
        "env": "DrivingTrack-v0",
        "env_kwargs": {"obs_type": "state"},
        "seeds": f"track_seed and episode seed 0-{args.tracks - 1}",
        "tracks": args.tracks,
        "depths": args.depths,
        "noise_levels": args.noise,
        "noise": "with probability p a step executes one of the two other actions, uniformly",
        "episode": "two laps (the registration's limits)",
        "source_crashes_per_lap": 5.4,
        "workers": args.workers,
        "machine": machine_at_start,
        "seconds": round(time.perf_counter() - start, 1),
        "rows": rows,
    }
    args.results.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.results, report)
    print(table(rows))
    print(f"wrote {args.results}")


if __name__ == "__main__":
    main()
