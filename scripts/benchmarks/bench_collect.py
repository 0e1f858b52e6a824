"""Collection throughput, as JSON: supervisor-labelled state–action pairs per minute.

FLUIDS-v0 at the velocity level, ego + 10 supervised cars + 5 pedestrians, quasi-LIDAR
observation (explicit where quasi-LIDAR is not available), the supervisor acting. For each
worker count, ``collect`` runs ``--episodes`` full episodes (seeds 0, 1, ...); the time
includes starting the workers, and a second "warm" run reuses the process pool's forkserver
(worker processes still start anew). ``raw_env_loop`` is the same episodes stepped in this
process without the collector (after one warm-up step: imports, caches, compiled kernels), the
ceiling for one worker; its ``pairs_per_cpu_min`` (CPU time)
is what one core gives when nothing else runs on it, and ``idle_estimate`` scales it by the
worker count (an estimate for cores of one's own; wall-clock rates fall when others share them).

    python scripts/benchmarks/bench_collect.py --episodes 200 --workers 1 2
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

import gymnasium as gym

import fluids_bench
from fluids_bench.core.provenance import announce
from fluids_bench.data.collect import collect
from fluids_bench.tasks.fluids.observations import OBS_TYPES

ENV_ID = "FLUIDS-v0"


def scenario() -> dict:
    obs_type = "qlidar" if "qlidar" in OBS_TYPES else "explicit"
    return {"action_level": "velocity", "num_cars": 10, "num_pedestrians": 5, "obs_type": obs_type}


def raw_loop(kwargs: dict, episodes: int) -> dict:
    env = gym.make(ENV_ID, **kwargs)
    env.step(env.reset(seed=10**6)[1]["supervisor_action"])  # one-time costs before the clock
    pairs, t0, cpu0 = 0, time.perf_counter(), time.process_time()
    for seed in range(episodes):
        _, info = env.reset(seed=seed)
        done = False
        while not done:
            _, _, term, trunc, info = env.step(info["supervisor_action"])
            pairs += 1
            done = term or trunc
    out = _rate(pairs, time.perf_counter() - t0)
    # CPU time, unlike wall time, does not grow when other processes share the cores
    out["pairs_per_cpu_min"] = round(pairs / (time.process_time() - cpu0) * 60.0)
    return out


def _rate(pairs: int, seconds: float) -> dict:
    return {
        "pairs": pairs,
        "seconds": round(seconds, 2),
        "pairs_per_min": round(pairs / seconds * 60.0),
    }


def timed_collect(kwargs: dict, episodes: int, workers: int) -> dict:
    t0 = time.perf_counter()
    trajectories = collect(ENV_ID, episodes, env_kwargs=kwargs, workers=workers, progress=False)
    return _rate(sum(len(t) for t in trajectories), time.perf_counter() - t0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--episodes",
        type=int,
        default=200,
        help="episodes per run (default 200, ~42,000 pairs: enough that the "
        "workers' ~2 s start-up does not dominate)",
    )
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()
    announce("~2 min on 2 cores at the defaults")
    kwargs = scenario()
    report = {
        "env": ENV_ID,
        "env_kwargs": kwargs,
        "episodes": args.episodes,
        "fluids_bench": fluids_bench.__version__,
        "python": platform.python_version(),
        "cpus": len(os.sched_getaffinity(0)),
        "load_average": os.getloadavg(),
        "raw_env_loop": raw_loop(kwargs, args.episodes),
        "collect": {},
    }
    per_core = report["raw_env_loop"]["pairs_per_cpu_min"]
    for workers in args.workers:
        cold = timed_collect(kwargs, args.episodes, workers)
        warm = timed_collect(kwargs, args.episodes, workers)
        # what the workers would give with a core each and nothing else running
        estimate = workers * per_core
        report["collect"][str(workers)] = {"cold": cold, "warm": warm, "idle_estimate": estimate}
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
