"""Env throughput with the supervisor's label every step, as JSON (any registered id).

Modes, each over ``--steps`` env steps on one env, episodes restarting (new seed) whenever they
end, resets included in the measured time:

* ``supervisor``: the supervisor acts (the executed action is ``info["supervisor_action"]``);
* ``supervisor_noise``: the supervisor's label plus N(0, (0.1 · half-range)²) noise, clipped
  (the DART setting: labels are asked in states off the supervisor's own path);
* ``random``: uniform random actions, the label still computed every step (a poor learner);
* ``pixels``: as ``supervisor`` with ``obs_type="pixels"`` (only for envs that have it).

An env that offers ``env.unwrapped.supervisor_stats()`` (``replans``, ``replan_seconds`` since the
last reset) also gets the mean cost of one replan and replans per 100 steps, on the clock the env
reads (Singulation-v0: wall clock; a CPU clock read costs up to milliseconds on some sandboxed
kernels; ``scripts/benchmarks/bench_singulation_replan.py`` measures its CPU cost per replan in batches).
Run on one core: ``taskset -c 0 python scripts/benchmarks/bench_tasks.py --env Singulation-v0``.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from typing import Any

import gymnasium as gym
import numpy as np
from _results import add_results_option, emit

import fluids_bench  # noqa: F401  (registers the ids)

MODES = ("supervisor", "supervisor_noise", "random", "pixels")


def bench(env_id: str, mode: str, steps: int, kwargs: dict[str, Any]) -> dict[str, Any]:
    if mode == "pixels":
        kwargs = {**kwargs, "obs_type": "pixels"}
    env = gym.make(env_id, **kwargs)
    space = env.action_space
    rng = np.random.default_rng(0)
    half = (space.high - space.low) / 2 if isinstance(space, gym.spaces.Box) else None
    # one-time costs (imports, first plan) before the clock starts
    obs, info = env.reset(seed=10**6)
    env.step(info["supervisor_action"])
    stats = getattr(env.unwrapped, "supervisor_stats", None)
    done = episodes = replans = 0
    replan_seconds = 0.0
    seed = 0
    t0, c0 = time.perf_counter(), time.process_time()
    while done < steps:
        obs, info = env.reset(seed=seed)
        seed += 1
        episodes += 1
        ended = False
        while not ended and done < steps:
            label = info["supervisor_action"]
            if mode == "random":
                action = space.sample()
            elif mode == "supervisor_noise" and half is not None:
                noisy = label + 0.1 * half * rng.standard_normal(space.shape)
                action = np.clip(noisy, space.low, space.high).astype(space.dtype)
            else:
                action = label
            obs, reward, terminated, truncated, info = env.step(action)
            ended = terminated or truncated
            done += 1
        if stats is not None:
            s = stats()
            replans += s["replans"]
            replan_seconds += s["replan_seconds"]
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    out: dict[str, Any] = {
        "steps": done,
        "episodes": episodes,
        "seconds": round(wall, 3),
        "steps_per_s": round(done / wall, 1),
        "steps_per_cpu_s": round(done / cpu, 1),
    }
    if stats is not None:
        out["replans_per_100_steps"] = round(100 * replans / done, 2)
        out["replan_ms_mean"] = round(1e3 * replan_seconds / max(replans, 1), 2)
        out["share_of_time_replanning"] = round(replan_seconds / wall, 3)  # of wall time
    env.close()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", default="Singulation-v0", help="registered env id")
    parser.add_argument("--steps", type=int, default=3000, help="env steps per mode")
    parser.add_argument("--modes", nargs="+", choices=MODES, default=list(MODES))
    parser.add_argument("--kwargs", default="{}", help="env kwargs as JSON")
    add_results_option(parser)
    args = parser.parse_args()
    print(
        f"expected run time: ~{max(1, round(args.steps * len(args.modes) / 1000))} s on one core",
        file=sys.stderr,
    )
    kwargs = json.loads(args.kwargs)
    results = {m: bench(args.env, m, args.steps, kwargs) for m in args.modes}
    emit(
        {
            "env": args.env,
            "kwargs": kwargs,
            "steps": args.steps,
            "python": platform.python_version(),
            "results": results,
        },
        args,
    )


if __name__ == "__main__":
    main()
