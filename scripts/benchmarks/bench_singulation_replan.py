"""The cost of one singulation replan and one reset, as JSON (CPU time, one core).

Collects ``--states`` seeded states of Singulation-v0 (initial states, and states after a few
random actions, where the fingertip is elsewhere and some objects moved), then times the
behaviour level (``plan_push``) on all of them, ``--repeats`` times, and the initial-state
sampler (``sample_cluster``) on as many seeds. CPU time is read once per batch (reading a CPU
clock costs up to milliseconds on some sandboxed kernels, so it is never read per call).
Compare two versions with ``scripts/benchmarks/bench_ab.py``:

    python scripts/benchmarks/bench_ab.py --base main --runs 5 -- bench_singulation_replan.py
"""

from __future__ import annotations

import argparse
import json
import time

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core.provenance import announce
from fluids_bench.tasks.singulation.sim import SceneConfig, sample_cluster
from fluids_bench.tasks.singulation.supervisor import plan_push


def states(count: int) -> list:
    env = gym.make("Singulation-v0")
    rng = np.random.default_rng(0)
    out = []
    for seed in range(count):
        env.reset(seed=seed)
        if seed % 2:  # half of them after 10 random actions
            for _ in range(10):
                env.step(rng.uniform(-1.0, 1.0, 2).astype(np.float32))
        world = env.unwrapped.world
        out.append((world, world.poses()))
        env = gym.make("Singulation-v0")  # keep each world: a new env for the next state
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--states", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    announce("~30 s on one core at the defaults")
    sample = states(args.states)
    plan_push(*sample[0])  # warm up
    c0 = time.process_time()
    for _ in range(args.repeats):
        for world, poses in sample:
            plan_push(world, poses)
    replan_cpu = time.process_time() - c0
    config = SceneConfig()
    c0 = time.process_time()
    for seed in range(args.states * args.repeats):
        sample_cluster(config, np.random.default_rng(seed))
    reset_cpu = time.process_time() - c0
    n = args.states * args.repeats
    print(
        json.dumps(
            {
                "replans": n,
                "replan_cpu_ms": round(1e3 * replan_cpu / n, 3),
                "replans_per_cpu_s": round(n / replan_cpu, 1),
                "cluster_samples": n,
                "cluster_sample_cpu_ms": round(1e3 * reset_cpu / n, 3),
                "cluster_samples_per_cpu_s": round(n / reset_cpu, 1),
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
