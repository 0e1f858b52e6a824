"""Speed of the locomotion IL envs: env steps/s with the supervisor's label every step, next to
Gymnasium's bare ``<Name>-v5`` in the same run (same seed, same random actions, one process).

Prints one JSON object. A policy supervisor's label is one small MLP forward pass; an MPC
label is a planning call, so ``--steps`` is counted per id and kind.

Example: ``python scripts/benchmarks/bench_locomotion.py --env Hopper-IL-v0 --kind policy --steps 3000``
"""

from __future__ import annotations

import argparse
import sys
import time

import gymnasium as gym
import numpy as np
from _results import add_results_option, emit

import fluids_bench  # noqa: F401  (registers the ids)


def steps_per_second(env: gym.Env, steps: int, seed: int) -> float:
    actions = np.random.default_rng(seed).uniform(
        env.action_space.low, env.action_space.high, (steps, env.action_space.shape[0])
    )
    env.reset(seed=seed)
    t0 = time.perf_counter()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - t0)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--env",
        nargs="+",
        default=["Hopper-IL-v0", "Walker2d-IL-v0", "HalfCheetah-IL-v0", "Humanoid-IL-v0"],
    )
    p.add_argument("--kind", default=None, help="supervisor kind (default: each id's)")
    p.add_argument("--steps", type=int, default=1000, help="steps per timed block")
    p.add_argument("--repeats", type=int, default=20, help="blocks per side, interleaved")
    p.add_argument("--seed", type=int, default=0)
    add_results_option(p)
    args = p.parse_args(argv)
    print(
        f"expected run time: ~{max(1, round(len(args.env) * args.repeats * args.steps / 4000))} s on one core (policy supervisors)",
        file=sys.stderr,
    )
    rows = []
    for env_id in args.env:
        name = env_id.split("-")[0]
        kwargs = {} if args.kind is None else {"supervisor": args.kind}
        il = gym.make(env_id, **kwargs)
        bare = gym.make(f"{name}-v5")
        # interleaved blocks, best of each: a drift in the machine's speed hits both sides alike
        bare_rates, il_rates = [], []
        for _ in range(args.repeats):
            bare_rates.append(steps_per_second(bare, args.steps, args.seed))
            il_rates.append(steps_per_second(il, args.steps, args.seed))
        best_bare, best_il = max(bare_rates), max(il_rates)
        rows.append(
            {
                "env_id": env_id,
                "supervisor": il.unwrapped.metadata["supervisor"]["kind"],
                "bare_steps_per_s": round(best_bare, 1),
                "labelled_steps_per_s": round(best_il, 1),
                "label_overhead_pct": round(100 * (best_bare / best_il - 1), 1),
                "steps": args.steps,
            }
        )
    emit(
        {
            "benchmark": "locomotion env steps/s, label every step vs Gymnasium's bare v5 env",
            "steps": args.steps,
            "repeats": args.repeats,
            "results": rows,
        },
        args,
        indent=1,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
