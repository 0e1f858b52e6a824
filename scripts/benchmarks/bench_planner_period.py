"""Step time of FLUIDS-v4 with the velocity planner every step (its Markov labels) against every
5th step (the plan-carrying label of v0-v3), side by side in one run, printed as JSON.

Each episode is driven by the supervisor's labels; both settings run the same seeds, interleaved
(so a busy machine slows both alike). CPU seconds per step (`time.process_time`).

    PYTHONPATH=. python scripts/benchmarks/bench_planner_period.py --episodes 6
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import add_results_option, emit  # noqa: E402

SEED = 500_000


def episode(env: gym.Env, seed: int) -> tuple[int, float]:
    _, info = env.reset(seed=seed)
    steps, start = 0, time.process_time()
    while True:
        _, _, terminated, truncated, info = env.step(info["supervisor_action"])
        steps += 1
        if terminated or truncated:
            return steps, time.process_time() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env-id", default="FLUIDS-v4")
    parser.add_argument("--episodes", type=int, default=6)
    parser.add_argument("--periods", type=int, nargs="+", default=[1, 5])
    add_results_option(parser)
    args = parser.parse_args()
    envs = {p: gym.make(args.env_id, planner_period=p) for p in args.periods}
    for env in envs.values():  # compile and warm up outside the timing
        episode(env, SEED - 1)
    totals = {p: [0, 0.0] for p in args.periods}
    for k in range(args.episodes):
        for p, env in envs.items():
            steps, seconds = episode(env, SEED + k)
            totals[p][0] += steps
            totals[p][1] += seconds
    out = {
        "env_id": args.env_id,
        "episodes": args.episodes,
        "seeds": [SEED, SEED + args.episodes - 1],
        "periods": {
            str(p): {"steps": s, "cpu_s": t, "ms_per_step": 1e3 * t / s}
            for p, (s, t) in totals.items()
        },
    }
    if len(args.periods) == 2:
        a, b = args.periods
        out[f"cost_{a}_over_{b}"] = float(
            np.divide(out["periods"][str(a)]["ms_per_step"], out["periods"][str(b)]["ms_per_step"])
        )
    emit(out, args)


if __name__ == "__main__":
    main()
