"""Sensor throughput, as JSON: FLUIDS-v0 steps per second with each observation family, and the
sensors' own cost per call.

Scenario S2 (as in ``bench_sim.py``): FLUIDS-v0 with an ego, 10 supervised background cars and
5 pedestrians, the supervisor's label every step and the ego following it. It is run with the
explicit observation (the baseline), quasi-LIDAR (64 rays), bird's-eye 84×84 and bird's-eye
400×400, with ``bench_sim.py``'s loop: episodes restart with a new seed when they end and
resets are timed too.

Sensor cost: along S2 episodes, every sensor configuration below observes the same world
states, each call timed on its own (median, mean and 10th-percentile microseconds; the
median of CPU time too). The renderer
(``render_mode="rgb_array"``, 640×640) is listed too, for reference.

Run on one core for steadier numbers: ``taskset -c 0 python scripts/benchmarks/bench_sensors.py``.
"""

from __future__ import annotations

import argparse
import inspect
import platform
import time

import gymnasium as gym
import numpy as np
from _results import add_results_option, emit
from bench_sim import bench_env  # the same S2 loop as the simulator benchmark (scripts/)

import fluids_bench
from fluids_bench.core.provenance import announce
from fluids_bench.tasks.fluids.sim.render import Renderer
from fluids_bench.tasks.fluids.sim.sensors.birdseye import BirdsEyeSensor
from fluids_bench.tasks.fluids.sim.sensors.qlidar import QLidarSensor

S2 = {"num_cars": 10, "num_pedestrians": 5, "action_level": "control"}
ENV_VARIANTS = {
    "S2 explicit": {"obs_type": "explicit"},
    "S2 + qlidar 64": {"obs_type": "qlidar", "lidar_rays": 64},
    "S2 + birdseye 84": {"obs_type": "birdseye", "birdseye_size": 84},
    # only where the code under test has it (bench_ab.py also runs older revisions)
    "S2 + qlidar v1 64": {"obs_type": "qlidar", "lidar_rays": 64, "lidar_version": 1},
    "S2 + birdseye 400": {"obs_type": "birdseye", "birdseye_size": 400},
}


HAS_V1 = "version" in inspect.signature(QLidarSensor).parameters
if not HAS_V1:
    del ENV_VARIANTS["S2 + qlidar v1 64"]


def sensor_table(layout) -> dict:
    v1 = {"qlidar v1 64": QLidarSensor(layout, 64, 30.0, version=1)} if HAS_V1 else {}
    return {
        **v1,
        "qlidar 64": QLidarSensor(layout, 64, 30.0),
        "qlidar 64 noise+dropout": QLidarSensor(layout, 64, 30.0, noise_var=0.1, dropout=0.1),
        "qlidar 256": QLidarSensor(layout, 256, 30.0),
        "birdseye 84 ego": BirdsEyeSensor(layout, 84, 40.0, "ego"),
        "birdseye 84 ego_rotated": BirdsEyeSensor(layout, 84, 40.0, "ego_rotated"),
        "birdseye 84 global": BirdsEyeSensor(layout, 84, 40.0, "global"),
        "birdseye 84 pixel noise": BirdsEyeSensor(layout, 84, 40.0, "ego", noise_var=16.0),
        "birdseye 400 ego": BirdsEyeSensor(layout, 400, 40.0, "ego"),
        "render 640 (rgb_array)": Renderer(layout),
    }


def bench_sensors(calls: int) -> dict:
    env = gym.make("FLUIDS-v0", **S2)
    _, info = env.reset(seed=0)
    sensors = sensor_table(env.unwrapped.world.layout)
    wall = {k: [] for k in sensors}
    cpu = {k: [] for k in sensors}
    rng = np.random.default_rng(0)
    seed = 0
    for _ in range(calls):
        world = env.unwrapped.world
        for name, sensor in sensors.items():
            t0, c0 = time.perf_counter(), time.thread_time()
            if isinstance(sensor, Renderer):
                sensor.render(world)
            else:
                sensor.observe(world, rng)
            wall[name].append(time.perf_counter() - t0)
            cpu[name].append(time.thread_time() - c0)
        _, _, term, trunc, info = env.step(info["supervisor_action"])
        if term or trunc:
            seed += 1
            _, info = env.reset(seed=seed)
    us = lambda xs, f: round(float(f(xs)) * 1e6, 1)  # noqa: E731
    return {
        name: {
            "median_us": us(wall[name], np.median),
            "mean_us": us(wall[name], np.mean),
            "median_cpu_us": us(cpu[name], np.median),
            # the fastest tenth: what a call costs when the machine is not busy elsewhere
            "p10_us": us(wall[name], lambda xs: np.percentile(xs, 10)),
            "calls": calls,
        }
        for name in sensors
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000, help="env steps per S2 variant")
    parser.add_argument("--calls", type=int, default=1000, help="timed calls per sensor")
    add_results_option(parser)
    args = parser.parse_args()
    announce("~1 min on one core at the defaults")
    # numpy's speed on tiny arrays, to compare machines (and loads) with each other
    a = np.zeros(64)
    t0 = time.perf_counter()
    for _ in range(20000):
        a + a
    add_ns = (time.perf_counter() - t0) / 20000 * 1e9
    results = {
        "sensor_cost": bench_sensors(args.calls),
        "env_steps": {
            name: bench_env({**S2, **kw}, args.steps) for name, kw in ENV_VARIANTS.items()
        },
    }
    emit(
        {
            "benchmark": "bench_sensors",
            "fluids_bench": fluids_bench.__version__,
            "python": platform.python_version(),
            "numpy": np.__version__,
            "numpy_add_64_ns": round(add_ns, 1),
            "steps": args.steps,
            "calls": args.calls,
            "results": results,
        },
        args,
    )


if __name__ == "__main__":
    main()
