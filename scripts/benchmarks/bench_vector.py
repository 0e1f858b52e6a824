"""Batched FLUIDS throughput, as JSON: the scalar env, SyncVectorEnv and the native vector env.

The scene is S2 on ``FLUIDS-v1`` (``bench_sim.py``'s S2 with v1's rules): the four-way, the ego
plus 10 supervised cars and 5 pedestrians (16 agents), the explicit observation, the
supervisor's label every step, and the ego follows it (at the control level, or
``--action-level``'s). Parts:

* ``batch``: env-steps per CPU-second of the scalar env (``gym.make``), ``SyncVectorEnv`` and
  the vector entry point at each B, and CPU microseconds per agent-step. Each measurement takes
  about ``--steps`` env-steps (``steps / B`` batch steps, at least 8); worlds autoreset when their
  episode ends (resets are timed, as in every benchmark here). Per B, the three run back to
  back, ``--repeats`` times; the median run counts, and the ratio to the scalar env is the
  median of the ratios within each block.
* ``agents``: the vector env at B = ``--agents-batch`` on the two-lane four-way with 5, 10, 20
  and 30 cars (30 is that layout's most with the ego) and 5 pedestrians.
* ``processes``: one process stepping a batch on one core, then two at once on two cores
  (each pinned to its own); the ratio of their total env-steps per wall-second.
* ``workers``: one batch of ``--workers-batch`` worlds stepped by one process and by
  ``num_workers=2`` (half in this process, half in a worker process), in alternating blocks of
  ``--worker-steps`` batch steps on the same worlds (the two envs stay in the same states); the
  median of the blocks' ratios of env-steps per wall-second. Unlike ``processes``, the two
  halves meet at every step (the actions of all worlds in, the results of all out).
* ``profile``: cProfile's split of the vector env's step at B = ``--agents-batch`` into its
  phases (see ``FluidsVectorEnv``): actions to controls, the world step with the fault record,
  the velocity planner, the rest of the supervisor (recovery check, PID proposal, labels), the
  observation, the infos, judging and rewards, resets, and the vector layer's own work. A
  deterministic profiler inflates Python calls: read fractions, not times.
* ``kernels``: CPU microseconds per env-step at B = ``--kernel-batch`` spent inside each of the
  step's compiled calls (timed by wrapping them), against the whole step: a floor for any
  design that keeps these kernels, however little Python runs around them.

The single-process parts run pinned to ``--core`` (default: the last core). Run it with both cores free for the
``processes`` part: ``nice -n 5 python scripts/benchmarks/bench_vector.py``.
"""

from __future__ import annotations

import argparse
import cProfile
import multiprocessing as mp
import os
import platform
import pstats
import time

import gymnasium as gym
import numpy as np
from _results import add_results_option, emit

import fluids_bench
from fluids_bench.core.provenance import announce

ENV_ID = "FLUIDS-v1"
S2 = {"num_cars": 10, "num_pedestrians": 5, "action_level": "control", "obs_type": "explicit"}


def agents(kwargs: dict) -> int:
    return 1 + kwargs["num_cars"] + kwargs["num_pedestrians"]


def make(kind: str, n: int, kwargs: dict):
    if kind == "scalar":
        return gym.make(ENV_ID, **kwargs)
    if kind == "workers":
        return gym.make_vec(
            ENV_ID, n, vectorization_mode="vector_entry_point", num_workers=2, **kwargs
        )
    mode = "sync" if kind == "sync" else "vector_entry_point"
    return gym.make_vec(ENV_ID, n, vectorization_mode=mode, **kwargs)


class Runner:
    """An env reset (seed 0) and warmed up, so imports, layout caches and compiled kernels are
    paid before the clock starts; ``run(k)`` takes k (batch) steps, every ego following its
    label. An ended episode restarts from the env's own generator (the scalar env calls
    ``reset()``, a vector env autoresets), so the scalar env drives exactly world 0's
    episodes."""

    def __init__(self, kind: str, n: int, kwargs: dict) -> None:
        self.kind, self.env = kind, make(kind, n, kwargs)
        _, self.info = self.env.reset(seed=0)
        self.run(3)

    def run(self, steps: int) -> None:
        env, info = self.env, self.info
        for _ in range(steps):
            _, _, term, trunc, info = env.step(info["supervisor_action"])
            if self.kind == "scalar" and (term or trunc):
                _, info = env.reset()
        self.info = info


def median_row(rows: list[dict], ratios: list[float] | None = None) -> dict:
    """The run with the median env-steps per CPU-second, every run's rate, and the median of
    the ratios to the scalar env measured next to each run."""
    rates = [r["steps_per_cpu_s"] for r in rows]
    out = dict(sorted(rows, key=lambda r: r["steps_per_cpu_s"])[len(rows) // 2])
    out["runs_steps_per_cpu_s"] = rates
    if ratios is not None:
        out["vs_scalar"] = round(float(np.median(ratios)), 3)
    return out


def batch_part(batches: list[int], steps: int, repeats: int) -> list[dict]:
    """Per B, blocks of scalar, SyncVectorEnv and vector env back to back, ``repeats`` times
    (the machine's speed drifts: only rates measured side by side compare)."""
    runs: dict[tuple[str, int], list[dict]] = {}
    ratios: dict[tuple[str, int], list[float]] = {}
    for _ in range(repeats):
        for n in batches:
            scalar = measure("scalar", 1, S2, steps)
            runs.setdefault(("scalar", 1), []).append(scalar)
            for kind in ("sync", "vector"):
                row = measure(kind, n, S2, steps)
                runs.setdefault((kind, n), []).append(row)
                ratios.setdefault((kind, n), []).append(
                    row["steps_per_cpu_s"] / scalar["steps_per_cpu_s"]
                )
    out = [median_row(runs[("scalar", 1)], [1.0])]
    for n in batches:
        out += [median_row(runs[(k, n)], ratios[(k, n)]) for k in ("sync", "vector")]
    return out


def measure(kind: str, n: int, kwargs: dict, steps: int) -> dict:
    runner = Runner(kind, n, kwargs)
    batch_steps = steps if kind == "scalar" else max(8, steps // n)
    t0, c0 = time.perf_counter(), time.process_time()
    runner.run(batch_steps)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    runner.env.close()
    env_steps = batch_steps * (1 if kind == "scalar" else n)
    return {
        "env": kind,
        "num_envs": n,
        "agents": agents(kwargs),
        "env_steps": env_steps,
        "cpu_seconds": round(cpu, 3),
        "seconds": round(wall, 3),
        "steps_per_cpu_s": round(env_steps / cpu, 1),
        "steps_per_s": round(env_steps / wall, 1),
        "us_per_agent_step": round(1e6 * cpu / env_steps / agents(kwargs), 2),
    }


# ---------------------------------------------------------------------- two processes
def _worker(core: int, n: int, batch_steps: int, kwargs: dict, barrier, out) -> None:
    os.sched_setaffinity(0, {core})
    runner = Runner("vector", n, kwargs)
    barrier.wait()
    t0, c0 = time.perf_counter(), time.process_time()
    runner.run(batch_steps)
    out.put((core, time.perf_counter() - t0, time.process_time() - c0))


def processes(n: int, batch_steps: int, kwargs: dict, cores: list[int]) -> dict:
    """Env-steps per wall-second of one process alone, then of ``len(cores)`` at once."""
    ctx = mp.get_context("fork")
    runs = {}
    for count in (1, len(cores)):
        barrier, out = ctx.Barrier(count), ctx.Queue()
        procs = [
            ctx.Process(target=_worker, args=(c, n, batch_steps, kwargs, barrier, out))
            for c in cores[:count]
        ]
        for p in procs:
            p.start()
        results = [out.get() for _ in procs]
        for p in procs:
            p.join()
        wall = max(r[1] for r in results)
        env_steps = n * batch_steps * count
        runs[str(count)] = {
            "processes": count,
            "cores": cores[:count],
            "env_steps": env_steps,
            "seconds": round(wall, 3),
            "cpu_seconds": [round(r[2], 3) for r in results],
            "steps_per_s": round(env_steps / wall, 1),
        }
    return {
        "num_envs": n,
        "batch_steps_per_process": batch_steps,
        "runs": runs,
        "ratio": round(runs[str(len(cores))]["steps_per_s"] / runs["1"]["steps_per_s"], 3),
    }


# ---------------------------------------------------------------------- worker processes
def workers(n: int, block_steps: int, blocks: int, kwargs: dict) -> dict:
    """Env-steps per wall-second of one batch of ``n`` worlds in one process and over two
    (``num_workers=2``), in alternating blocks; the median of the blocks' ratios."""
    runners = {kind: Runner(kind, n, kwargs) for kind in ("vector", "workers")}
    rates: dict[str, list[float]] = {kind: [] for kind in runners}
    for _ in range(blocks):
        for kind, runner in runners.items():
            t0 = time.perf_counter()
            runner.run(block_steps)
            rates[kind].append(n * block_steps / (time.perf_counter() - t0))
    for runner in runners.values():
        runner.env.close()
    ratios = [w / v for v, w in zip(rates["vector"], rates["workers"], strict=True)]
    return {
        "num_envs": n,
        "num_workers": 2,
        "block_steps": block_steps,
        "blocks": blocks,
        "one_process_steps_per_s": round(float(np.median(rates["vector"])), 1),
        "two_workers_steps_per_s": round(float(np.median(rates["workers"])), 1),
        "runs_one_process": [round(r, 1) for r in rates["vector"]],
        "runs_two_workers": [round(r, 1) for r in rates["workers"]],
        "ratio": round(float(np.median(ratios)), 3),
    }


# ---------------------------------------------------------------------- profile
def _cum(
    stats: pstats.Stats,
    path: str,
    name: str,
    callers: tuple[tuple[str, str], ...] = (),
    required: bool = True,
) -> float:
    """Cumulative seconds of ``path:name``, counting only calls from ``callers`` if given.
    ``required``: the function must have been called (a renamed or moved function would
    otherwise silently move its time into the glue)."""
    total, found = 0.0, False
    for (file, _, func), (_, _, _, ct, by) in stats.stats.items():
        if func != name or not file.endswith(path):
            continue
        if not callers:
            total, found = total + ct, True
            continue
        for (cfile, _, cfunc), value in by.items():
            if any(cfile.endswith(p) and cfunc == f for p, f in callers):
                total, found = total + value[3], True
    if required and not found:
        raise RuntimeError(
            f"bench_vector: the profile has no call of {path}:{name} from {callers or 'anywhere'}; "
            "update the profile's parts to the code's current names"
        )
    return total


ENV = "fluids/env.py"
VECTOR = "fluids/vector/env.py"
IN_STEP = ((VECTOR, "step"),)
# the step rules' calls from the vector step: fluids/core/rules.py's (and, for bench_ab against an
# older tree, the vector env's own copy of them, vector/judge.py)
JUDGING = (
    *(("core/rules.py", f) for f in ("violations", "judge_worlds", "subjects", "succeeded")),
    ("core/rules.py", "step_rewards"),
    ("vector/judge.py", "judge_worlds"),
    ("vector/judge.py", "report_worlds"),
)


def profile(n: int, batch_steps: int, kwargs: dict) -> dict:
    runner = Runner("vector", n, kwargs)
    prof = cProfile.Profile()
    prof.enable()
    runner.run(batch_steps)
    prof.disable()
    stats = pstats.Stats(prof)
    vector_step = _cum(stats, VECTOR, "step")
    planner = _cum(
        stats, "supervisor/batch.py", "plan_velocities", (("supervisor/batch.py", "plan"),)
    )
    # (a list comprehension is its own frame before Python 3.12)
    in_infos = (("vector/infos.py", "step_infos"), ("vector/infos.py", "<listcomp>"))
    # labels: read from the rows (asked of each env only where its episode just ended)
    labels = _cum(stats, ENV, "supervisor_action", in_infos, required=False) + _cum(
        stats, "core/labels.py", "label_rows", IN_STEP, required=False
    )
    # the phases of a vector step (FluidsVectorEnv's docstring), each for all worlds
    parts = {
        "actions to controls": _cum(stats, VECTOR, "_act_all", IN_STEP),
        "world step and fault record": _cum(stats, "sim/batch.py", "step", IN_STEP)
        + _cum(stats, "sim/batch.py", "update", IN_STEP),
        "velocity planner": planner,
        "supervisor: recovery check, proposal, labels": _cum(
            stats, "supervisor/batch.py", "plan", IN_STEP
        )
        - planner
        + _cum(stats, "supervisor/batch.py", "propose", IN_STEP)
        + labels,
        "observation": _cum(stats, VECTOR, "_observe", IN_STEP),
        "infos (without labels)": _cum(stats, "vector/infos.py", "step_infos", IN_STEP) - labels,
        "judging and rewards": sum(
            _cum(stats, path, name, IN_STEP, required=False) for path, name in JUDGING
        ),
        "resets": _cum(stats, ENV, "reset", IN_STEP, required=False),
    }
    # the vector layer's own work: action checks, autoreset checks, result arrays
    parts["vector layer"] = vector_step - sum(parts.values())
    return {
        "num_envs": n,
        "batch_steps": batch_steps,
        "profiled_seconds": round(vector_step, 3),
        "fractions": {k: round(v / vector_step, 4) for k, v in parts.items()},
    }


# ---------------------------------------------------------------------- compiled share
# the vector step's compiled calls, by the module attribute the step looks them up through
KERNELS = {
    "world step (advance_worlds)": ("fluids_bench.tasks.fluids.sim.kernels", "advance_worlds"),
    "fault record (record_steps)": ("fluids_bench.tasks.fluids.sim.batch", "record_steps"),
    "off-route check": ("fluids_bench.tasks.fluids.supervisor.batch", "mark_off_route_worlds"),
    "velocity planner, first half": ("fluids_bench.tasks.fluids.supervisor.batch", "plan_head_worlds"),
    "velocity planner, second half": ("fluids_bench.tasks.fluids.supervisor.batch", "plan_tail_worlds"),
    "PID (proposals, labels)": ("fluids_bench.tasks.fluids.supervisor.batch", "pid_follow_worlds"),
    "observation (fill_explicit_worlds)": ("fluids_bench.tasks.fluids.observations", "fill_explicit_worlds"),
}  # fmt: skip


def kernels(n: int, batch_steps: int, kwargs: dict) -> dict:
    """CPU µs per env-step inside each compiled call of the vector step, and the whole step."""
    import importlib

    spent = dict.fromkeys(KERNELS, 0.0)

    def timer(part: str, f):
        def timed(*args):
            t = time.process_time()
            try:
                return f(*args)
            finally:
                spent[part] += time.process_time() - t

        return timed

    originals = {}
    for part, (module, name) in KERNELS.items():
        mod = importlib.import_module(module)
        originals[part] = (mod, name, getattr(mod, name))
        setattr(mod, name, timer(part, getattr(mod, name)))
    try:
        runner = Runner("vector", n, kwargs)
        spent.update(dict.fromkeys(KERNELS, 0.0))
        c0 = time.process_time()
        runner.run(batch_steps)
        cpu = time.process_time() - c0
    finally:
        for mod, name, f in originals.values():
            setattr(mod, name, f)
    env_steps = n * batch_steps
    per = {k: round(1e6 * v / env_steps, 2) for k, v in spent.items()}
    return {
        "num_envs": n,
        "env_steps": env_steps,
        "us_per_env_step": round(1e6 * cpu / env_steps, 2),
        "compiled_us_per_env_step": round(sum(per.values()), 2),
        "by_call": per,
    }


# ---------------------------------------------------------------------- plot
def plot(data: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.8))
    rows = data["batch"]
    scalar = next(r for r in rows if r["env"] == "scalar")
    for kind, label in (("sync", "SyncVectorEnv"), ("vector", "vector entry point")):
        pts = [(r["num_envs"], r["steps_per_cpu_s"]) for r in rows if r["env"] == kind]
        left.plot(*zip(*pts, strict=True), marker="o", label=label)
    left.axhline(scalar["steps_per_cpu_s"], color="grey", ls="--", label="scalar env")
    left.set_xscale("log", base=2)
    left.set_xlabel("worlds per batch (B)")
    left.set_ylabel("env-steps per CPU-second")
    left.set_ylim(bottom=0)
    left.legend()
    left.set_title(f"{ENV_ID} S2 with labels")
    pts = [(r["agents"], r["us_per_agent_step"]) for r in data["agents"]]
    right.plot(*zip(*pts, strict=True), marker="o")
    right.set_xlabel("agents per world (the ego, the cars, 5 pedestrians)")
    right.set_ylabel("CPU µs per agent-step")
    right.set_ylim(bottom=0)
    right.set_title(f"vector entry point, B = {data['agents_batch']}, two-lane four-way")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=3000, help="env-steps per measurement")
    parser.add_argument(
        "--repeats", type=int, default=3, help="blocks of scalar, sync, vector per B (median)"
    )
    parser.add_argument("--batches", type=int, nargs="+", default=[1, 4, 16, 64, 256])
    parser.add_argument("--cars", type=int, nargs="+", default=[5, 10, 20, 30])
    parser.add_argument("--agents-batch", type=int, default=16, help="B of the agents part")
    parser.add_argument(
        "--process-steps", type=int, default=32000, help="env-steps per process (processes part)"
    )
    parser.add_argument("--workers-batch", type=int, default=128, help="B of the workers part")
    parser.add_argument(
        "--worker-steps", type=int, default=100, help="batch steps per block (workers part)"
    )
    parser.add_argument("--worker-blocks", type=int, default=10, help="blocks (workers part)")
    parser.add_argument("--profile-steps", type=int, default=1000, help="env-steps profiled")
    parser.add_argument("--kernel-batch", type=int, default=64, help="B of the kernels part")
    parser.add_argument(
        "--core",
        type=int,
        default=None,
        help="core of the single-process parts (default: the last)",
    )
    parser.add_argument("--image", default=None, help="also plot to this PNG")
    parser.add_argument(
        "--action-level",
        default=S2["action_level"],
        choices=["behavior", "trajectory", "velocity", "control"],
        help="the ego's action level in every part (the supervisor labels every step)",
    )
    add_results_option(parser)
    args = parser.parse_args()
    S2["action_level"] = args.action_level
    measurements = 3 * len(args.batches) * args.repeats + 3 * len(args.cars)
    announce(
        f"~{max(1, round(args.steps * measurements / 2500 / 60))} min on a quiet 2-core machine"
    )
    everywhere = os.sched_getaffinity(0)
    core = max(everywhere) if args.core is None else args.core
    os.sched_setaffinity(0, {core})
    batch = batch_part(args.batches, args.steps, args.repeats)
    agents_rows = [
        measure("vector", args.agents_batch, {**S2, "lanes": 2, "num_cars": c}, args.steps // 2)
        for c in args.cars
    ]
    split = profile(args.agents_batch, max(4, args.profile_steps // args.agents_batch), S2)
    compiled = kernels(args.kernel_batch, max(8, args.steps // args.kernel_batch), S2)
    os.sched_setaffinity(0, everywhere)
    cores = sorted(everywhere)[:2]
    pair = together = None
    if len(cores) == 2:
        pair = processes(
            args.agents_batch, max(8, args.process_steps // args.agents_batch), S2, cores
        )
        together = workers(args.workers_batch, args.worker_steps, args.worker_blocks, S2)
    data = {
        "benchmark": "bench_vector",
        "fluids_bench": fluids_bench.__version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "env_id": ENV_ID,
        "scene": S2,
        "seeds": "world i of a batch: seed i, then its own generator on autoreset; the scalar "
        "env: seed 0, then reset() (world 0's episodes)",
        "steps": args.steps,
        "pinned_core": core,
        "agents_batch": args.agents_batch,
        "repeats": args.repeats,
        "batch": batch,
        "agents": agents_rows,
        "processes": pair,
        "workers": together,
        "profile": split,
        "kernels": compiled,
    }
    if args.image:
        plot(data, args.image)
    emit(data, args)


if __name__ == "__main__":
    main()
