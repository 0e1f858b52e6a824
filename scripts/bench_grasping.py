"""Speed of GraspingInClutter-v0 on one core, as JSON.

- ``env_steps_per_second``: ``env.step`` with the supervisor's label computed every step (it is
  in ``info``) and executed, whole episodes from ``reset`` (the replans they need included),
  for the state observation and for 96×96 pixels;
- ``replan_ms``: one replan (rank the corridors, simulate candidates on rebuilt worlds until one
  grasps cleanly) from fresh scenes; ``label_us``: a label between replans (the cached plan's
  waypoint and P-control);
- wall-clock and CPU (``time.process_time``) figures both: on a shared machine the CPU figure
  is the one an idle core would show.

Usage: ``python scripts/bench_grasping.py --episodes 100``. Needs the package importable.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.tasks.grasping.sim import GraspConfig, GraspWorld, sample_scene
from fluids_bench.tasks.grasping.supervisor import GraspSupervisor, corridor_action

ENV_ID = "GraspingInClutter-v0"


def env_speed(obs_type: str, episodes: int) -> dict:
    env = gym.make(ENV_ID, obs_type=obs_type)
    env.reset(seed=10_000)  # compile / load the numba kernel outside the timing
    steps = 0
    wall, cpu = time.perf_counter(), time.process_time()
    for seed in range(episodes):
        _, info = env.reset(seed=seed)
        done = False
        while not done:
            _, _, terminated, truncated, info = env.step(info["supervisor_action"])
            steps += 1
            done = terminated or truncated
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    return {
        "obs_type": obs_type,
        "episodes": episodes,
        "steps": steps,
        "env_steps_per_second_wall": steps / wall,
        "env_steps_per_second_cpu": steps / cpu,
    }


def replan_cost(scenes: int) -> dict:
    cfg = GraspConfig()
    sup = GraspSupervisor(cfg)
    times = []
    for seed in range(scenes):
        world = GraspWorld(cfg, sample_scene(cfg, np.random.default_rng(seed)))
        start = time.process_time()
        plan = sup.plan(world)
        times.append(time.process_time() - start)
    world = GraspWorld(cfg, sample_scene(cfg, np.random.default_rng(0)))
    reps = 2000
    start = time.process_time()
    for _ in range(reps):
        corridor_action(world, plan.corridor.heading)
    label = (time.process_time() - start) / reps
    t = np.array(times) * 1e3
    return {
        "replans": scenes,
        "replan_ms_cpu_mean": float(t.mean()),
        "replan_ms_cpu_median": float(np.median(t)),
        "replan_ms_cpu_p90": float(np.percentile(t, 90)),
        "label_us_cpu": label * 1e6,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--replans", type=int, default=100)
    args = parser.parse_args()
    report = {
        "env": ENV_ID,
        "cpu_count": os.cpu_count(),
        "load_average": os.getloadavg(),
        "state": env_speed("state", args.episodes),
        "pixels": env_speed("pixels", args.episodes),
        "replan": replan_cost(args.replans),
    }
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
