"""The velocity planner's compiled kernels, replayed, as JSON: µs per call.

Records the arguments of every :func:`defensive_kernels.defensive_forbid` and
:func:`kernels.plan_conflicts` call (its two costliest kernels) and of every
:func:`plan_kernels.plan_head` and :func:`plan_kernels.plan_tail` call (the whole compiled tick)
of seeded ``FLUIDS-v1`` episodes in the S2 scene (the four-way, the ego plus 10 supervised cars
and 5 pedestrians, the control level, the explicit observation; the ego follows the
supervisor's label, so as the learner's it is uncontrolled and ``defensive_forbid`` runs at
every plan), then replays those calls in recorded order, ``--repeats`` times, pinned to
``--core``: the median replay's wall time per call counts (µs, ``time.perf_counter``). Each
kernel's outputs are hashed over the replay (``outputs_sha256``; for ``plan_tail`` also the
targets it writes into its ``out`` argument), so two revisions that should agree bit for bit
can be compared from their JSON.

Run it pinned and on a quiet core, e.g. ``taskset -c 0 python
scripts/benchmarks/bench_planner_kernels.py``; compare revisions by running it on each with
its own ``PYTHONPATH``, interleaved (speeds of a shared machine only compare side by side).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import platform
import statistics
import time

import gymnasium as gym
import numpy as np
from _results import add_results_option, emit

import fluids_bench
from fluids_bench.core.provenance import announce
from fluids_bench.tasks.fluids.supervisor import velocity

ENV_ID = "FLUIDS-v1"
S2 = {"num_cars": 10, "num_pedestrians": 5, "action_level": "control", "obs_type": "explicit"}
# recorded from the step-by-step plan (where each inner kernel is a Python call), and from the
# compiled plan (its two halves)
STEPWISE_KERNELS = ("defensive_forbid", "plan_conflicts")
COMPILED_KERNELS = ("plan_head", "plan_tail")
KERNELS = STEPWISE_KERNELS + COMPILED_KERNELS
WRITES_OUT = {"plan_tail"}  # kernels whose last argument is an output


class Recorder:
    """Stands in for a kernel in :mod:`velocity`'s namespace: copies each call's arguments
    (the world's arrays change in place as it steps; equal arrays are stored once) and calls
    the kernel."""

    def __init__(self, kernel) -> None:
        self.kernel, self.calls, self._seen = kernel, [], {}

    def _keep(self, arg):
        if not isinstance(arg, np.ndarray):
            return arg
        key = (arg.dtype.str, arg.shape, hashlib.sha256(np.ascontiguousarray(arg)).digest())
        return self._seen.setdefault(key, arg.copy())

    def __call__(self, *args):
        self.calls.append(tuple(self._keep(a) for a in args))
        return self.kernel(*args)


def record(episodes: int, max_steps: int, names: tuple[str, ...], stepwise: bool):
    """Every call of the kernels ``names`` (in :mod:`velocity`'s namespace) in ``episodes``
    seeded episodes (seed 0, 1, ...) of at most ``max_steps`` steps each, the env planning
    step by step (:meth:`VelocityPlanner.plan_stepwise`) with ``stepwise``."""
    recorders = {name: Recorder(getattr(velocity, name)) for name in names}
    for name, rec in recorders.items():
        setattr(velocity, name, rec)
    # the env's plan runs the inner kernels inside one compiled call; the step-by-step plan
    # (equal to it bit for bit) calls them from Python, where the recorders stand in
    compiled_plan = velocity.VelocityPlanner.plan
    if stepwise:
        velocity.VelocityPlanner.plan = velocity.VelocityPlanner.plan_stepwise
    try:
        env = gym.make(ENV_ID, **S2)
        for seed in range(episodes):
            _, info = env.reset(seed=seed)
            for _ in range(max_steps):
                _, _, term, trunc, info = env.step(info["supervisor_action"])
                if term or trunc:
                    break
        env.close()
    finally:
        velocity.VelocityPlanner.plan = compiled_plan
        for name, rec in recorders.items():
            setattr(velocity, name, rec.kernel)
    return {name: rec.calls for name, rec in recorders.items()}


def _digest(h, out) -> None:
    for part in out if isinstance(out, tuple) else (out,):
        part = np.asarray(part)
        h.update(str((part.dtype.str, part.shape)).encode())
        h.update(np.ascontiguousarray(part))


def replay(kernel, calls: list[tuple], repeats: int, writes_out: bool = False) -> dict:
    """Median µs per call over ``repeats`` replays of ``calls`` (after one untimed warm-up
    replay, which also hashes the outputs; with ``writes_out``, also each call's last
    argument after it: calls of one shape share that array, so entries a call does not
    write keep an earlier call's, the same in every revision)."""
    h = hashlib.sha256()
    for args in calls:
        _digest(h, kernel(*args))
        if writes_out:
            _digest(h, args[-1])
    runs = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for args in calls:
            kernel(*args)
        runs.append(1e6 * (time.perf_counter() - t0) / len(calls))
    return {
        "calls": len(calls),
        "us_per_call": round(statistics.median(runs), 2),
        "runs_us_per_call": [round(r, 2) for r in runs],
        "outputs_sha256": h.hexdigest(),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=8, help="seeded episodes recorded")
    parser.add_argument("--max-steps", type=int, default=400, help="env-steps per episode at most")
    parser.add_argument("--repeats", type=int, default=15, help="timed replays (median)")
    parser.add_argument("--core", type=int, default=None, help="core to pin to (default: the last)")
    add_results_option(parser)
    args = parser.parse_args()
    announce(
        f"~{round(2 + args.episodes / 2 + args.repeats / 8)} s on one core (and compiling, cold)"
    )
    core = max(os.sched_getaffinity(0)) if args.core is None else args.core
    os.sched_setaffinity(0, {core})
    calls = record(args.episodes, args.max_steps, STEPWISE_KERNELS, stepwise=True)
    calls |= record(args.episodes, args.max_steps, COMPILED_KERNELS, stepwise=False)
    kernels = {
        name: replay(getattr(velocity, name), calls[name], args.repeats, name in WRITES_OUT)
        for name in KERNELS
    }
    emit(
        {
            "benchmark": "bench_planner_kernels",
            "fluids_bench": fluids_bench.__version__,
            "python": platform.python_version(),
            "numpy": np.__version__,
            "env_id": ENV_ID,
            "scene": S2,
            "episodes": args.episodes,
            "max_steps": args.max_steps,
            "repeats": args.repeats,
            "pinned_core": core,
            "kernels": kernels,
        },
        args,
    )


if __name__ == "__main__":
    main()
