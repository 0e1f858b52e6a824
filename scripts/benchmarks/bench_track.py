"""DrivingTrack throughput, as JSON: env steps per second with the supervisor's label every step.

Cases (each drives with the label it is given, so every step costs a label):
- ``hog``: DrivingTrack-v0 as registered (HOG observations, depth 8); the issue's target is
  >= 1,000 steps/s on one core;
- ``hog_source``: DrivingTrack-Source-v0 (depth 1);
- ``pixels`` and ``state``: the other observation types at the default depth.
Episodes restart with a new seed (a new track) when they end; resets are in the measured time.
Also the cost of the pieces, per call: the label (a fresh search, no cache), the frame, HOG.
Run on one core: ``taskset -c 0 python scripts/benchmarks/bench_track.py``.
"""

from __future__ import annotations

import argparse
import sys
import time

import gymnasium as gym
import numpy as np
from _results import add_results_option, emit

import fluids_bench
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.tasks.track.features import BirdsEye, hog_descriptor
from fluids_bench.tasks.track.sim import TrackConfig, generate_track
from fluids_bench.tasks.track.supervisor import SearchSupervisor


def bench_env(env_id: str, steps: int, **kwargs) -> dict:
    env = gym.make(env_id, **kwargs)
    _, info = env.reset(seed=10**6)  # one-time costs (kernels, HOG object) before the clock
    env.step(info[SUPERVISOR_ACTION_KEY])
    done, episodes, seed = 0, 0, 0
    t0, c0 = time.perf_counter(), time.process_time()
    _, info = env.reset(seed=seed)
    while done < steps:
        _, _, terminated, truncated, info = env.step(info[SUPERVISOR_ACTION_KEY])
        done += 1
        if terminated or truncated:
            episodes += 1
            seed += 1
            _, info = env.reset(seed=seed)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {
        "steps": done,
        "episodes": episodes,
        "steps_per_s": round(done / wall, 1),
        "steps_per_cpu_s": round(done / cpu, 1),
    }


def per_call_us(fn, calls: int) -> float:
    fn(0)
    t0 = time.process_time()
    for i in range(calls):
        fn(i)
    return round((time.process_time() - t0) / calls * 1e6, 1)


def bench_pieces(calls: int) -> dict:
    config = TrackConfig()
    track = generate_track(np.random.default_rng(0), config)
    rng = np.random.default_rng(1)
    poses = [track.point_at(a) for a in rng.uniform(0, track.perimeter, calls + 1)]
    view, hog = BirdsEye(track, config.workspace), hog_descriptor()
    image = view.frame(*poses[0])
    out = {}
    for depth in (1, 4, 8, 10):
        sup = SearchSupervisor(track, config, depth)
        out[f"label_depth_{depth}_us"] = per_call_us(lambda i, s=sup: s.plan(*poses[i]), calls)
    out["frame_us"] = per_call_us(lambda i: view.frame(*poses[i]), calls)
    out["frame_full_pipeline_us"] = per_call_us(lambda i: view.frame_reference(*poses[i]), calls)
    out["hog_us"] = per_call_us(lambda i: hog.compute(image), calls)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5000)
    add_results_option(parser)
    args = parser.parse_args()
    print(
        f"expected run time: ~{max(1, round(args.steps * 2.5 / 1000))} s on one core",
        file=sys.stderr,
    )
    result = {
        "fluids_bench": fluids_bench.__version__,
        "steps": args.steps,
        "hog": bench_env("DrivingTrack-v0", args.steps),
        "hog_source": bench_env("DrivingTrack-Source-v0", args.steps),
        "pixels": bench_env("DrivingTrack-v0", args.steps, obs_type="pixels"),
        "state": bench_env("DrivingTrack-v0", args.steps, obs_type="state"),
        "pieces_cpu_us": bench_pieces(1000),
    }
    emit(result, args)


if __name__ == "__main__":
    main()
