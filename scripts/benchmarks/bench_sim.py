"""Simulator throughput, as JSON: steps per second of the FLUIDS scenarios of issue #2.

S1: four-way with lights, 4 supervised cars + 2 pedestrians, no observation (world + supervisor).
S2: FLUIDS-v0, ego + 10 supervised cars + 5 pedestrians, explicit observation, the supervisor's
    label every step (the ego follows it).
S2v1: the same scene as FLUIDS-v1 (background drivers defensive toward the ego, lights obeyed,
    cars yield to pedestrians): what the defensive planner costs next to S2.
S3: 20 supervised cars + 10 pedestrians on the two-lane four-way, no observation.

Episodes restart (new seed) whenever they end; resets are part of the measured time. One-time
start-up costs (imports, layout caches, loading compiled kernels) are paid before the clock
starts.
Run on one core: `taskset -c 0 python scripts/benchmarks/bench_sim.py`.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time

import gymnasium as gym
import numpy as np
from _results import add_results_option, emit

import fluids_bench
from fluids_bench.tasks.fluids.sim.config import SceneConfig
from fluids_bench.tasks.fluids.supervisor.episode import make_world
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor, SupervisorConfig
from fluids_bench.tasks.fluids.supervisor.velocity import VelocityPlannerConfig


def _result(done: int, episodes: int, t0: float, c0: float) -> dict:
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    # CPU time is reported too: on a shared machine it is steadier than wall time
    return {
        "steps": done,
        "episodes": episodes,
        "seconds": round(wall, 3),
        "cpu_seconds": round(cpu, 3),
        "steps_per_s": round(done / wall, 1),
        "steps_per_cpu_s": round(done / cpu, 1),
    }


def _warm_up(step) -> None:
    """A few steps before the clock starts: one-time costs (imports, layout caches, loading the
    planner's compiled kernels) are not throughput."""
    for _ in range(3):
        step()


def bench_world(scene: SceneConfig, steps: int, period: int) -> dict:
    cfg = SupervisorConfig(velocity=VelocityPlannerConfig(period=period))
    _warm_up(lambda: DrivingSupervisor(world := make_world(scene, 10**6), cfg).step(world))
    done, seed, t0, c0 = 0, 0, time.perf_counter(), time.process_time()
    while done < steps:
        world = make_world(scene, seed)
        sup = DrivingSupervisor(world, cfg)
        while world.active.any() and world.steps < 1500 and done < steps:
            sup.step(world)
            done += 1
        seed += 1
    return _result(done, seed, t0, c0)


def bench_env(kwargs: dict, steps: int, env_id: str = "FLUIDS-v0") -> dict:
    env = gym.make(env_id, **kwargs)
    _warm_up(lambda: env.step(env.reset(seed=10**6)[1]["supervisor_action"]))
    done, seed, t0, c0 = 0, 0, time.perf_counter(), time.process_time()
    while done < steps:
        _, info = env.reset(seed=seed)
        seed += 1
        while done < steps:
            _, _, term, trunc, info = env.step(info["supervisor_action"])
            done += 1
            if term or trunc:
                break
    return _result(done, seed, t0, c0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=3000, help="steps per scenario")
    parser.add_argument(
        "--period", type=int, default=None, help="velocity-planner period (default: the env's)"
    )
    parser.add_argument(
        "--only", nargs="*", default=None, help="scenario names to run (S1 S2 S2v1 S3)"
    )
    add_results_option(parser)
    args = parser.parse_args()
    print(
        f"expected run time: ~{max(1, round(args.steps * 3 / 2000))} s per scenario, one core",
        file=sys.stderr,
    )
    period = args.period
    env_period = {} if period is None else {"planner_period": period}
    world_period = period if period is not None else VelocityPlannerConfig().period
    s2 = {"num_cars": 10, "num_pedestrians": 5, "action_level": "control", **env_period}
    scenarios = {
        "S1": lambda: bench_world(
            SceneConfig(num_cars=4, num_pedestrians=2), args.steps, world_period
        ),
        "S2": lambda: bench_env(s2, args.steps),
        "S2v1": lambda: bench_env(s2, args.steps, "FLUIDS-v1"),
        "S3": lambda: bench_world(
            SceneConfig(lanes=2, num_cars=20, num_pedestrians=10), args.steps, world_period
        ),
    }
    results = {name: fn() for name, fn in scenarios.items() if not args.only or name in args.only}
    emit(
        {
            "benchmark": "bench_sim",
            "fluids_bench": fluids_bench.__version__,
            "python": platform.python_version(),
            "numpy": np.__version__,
            "steps": args.steps,
            "results": results,
        },
        args,
    )


if __name__ == "__main__":
    main()
