"""Evaluation episodes one by one against B at a time on the vector env, as JSON.

`evaluate`'s two paths (`fluids_bench.benchmark.episodes`) on the same FLUIDS-v4 test
episodes (the suite's test seeds, from the first): `run_episode` for each (the scalar env, the
path of `batch=1` and of policies that cannot act on a batch) and `run_vector_jobs` with B
worlds (`batch=B`, the default for random, the supervisor, SB3 models and learners), for the
random policy and the supervisor. It reports the CPU seconds of this process (user + system)
and the wall seconds of each, the env-steps, and whether both paths gave the same rows (they
must). A few episodes first pay for imports, the layout and the compiled kernels.

    nice python scripts/benchmarks/bench_evaluate.py --episodes 100 --batches 16 32 64 \
        --results docs/results/bench_evaluate.json
"""

from __future__ import annotations

import argparse
import time

from _results import add_results_option, emit

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.benchmark import episodes
from fluids_bench.benchmark.policies import PolicySource
from fluids_bench.benchmark.suite import FLUIDS_ID, SUITE
from fluids_bench.core.provenance import announce

POLICIES = ("random", "supervisor")


def _timed(run) -> tuple[list[dict], dict]:
    cpu, wall = time.process_time(), time.perf_counter()
    rows = run()
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    steps = sum(r["length"] for r in rows)
    return rows, {
        "cpu_s": round(cpu, 3),
        "wall_s": round(wall, 3),
        "steps": steps,
        "steps_per_cpu_s": round(steps / cpu, 1),
    }


def _vector(jobs: list, task, batch: int) -> list[dict]:
    rows: list[dict] = []
    episodes.run_vector_jobs(jobs, task, rows.append, batch)
    return rows


def measure(policy: str, seeds: list[int], batches: list[int]) -> dict:
    task = next(t for t in SUITE.tasks if t.env_id == FLUIDS_ID)
    episodes.init_worker({(policy, task.name): PolicySource(policy, policy, policy)})
    text = episodes.kwargs_json(dict(task.env_kwargs))
    jobs = [episodes.EpisodeJob(policy, task.name, "test", FLUIDS_ID, text, s) for s in seeds]
    warm = [episodes.EpisodeJob(policy, task.name, "warm", FLUIDS_ID, text, 10**6 + i)
            for i in range(2)]  # fmt: skip
    for job in warm:
        episodes.run_episode(job, task)
    episodes.run_vector_jobs(warm, task, lambda row: None, 2)
    scalar_rows, scalar = _timed(lambda: [episodes.run_episode(j, task) for j in jobs])
    out: dict = {"scalar": scalar, "vector": {}}
    for batch in batches:
        rows, vector = _timed(lambda b=batch: _vector(jobs, task, b))
        vector["rows_equal"] = sorted(rows, key=lambda r: r["seed"]) == scalar_rows
        vector["cpu_speedup"] = round(scalar["cpu_s"] / vector["cpu_s"], 2)
        out["vector"][str(batch)] = vector
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=100, help="test episodes per policy")
    parser.add_argument("--batches", type=int, nargs="+", default=[16, 32, 64], help="B values")
    parser.add_argument("--policies", nargs="+", default=list(POLICIES), choices=POLICIES)
    add_results_option(parser)
    args = parser.parse_args()
    announce(f"about {args.episodes * (1 + len(args.batches)) // 4} CPU-s")
    task = next(t for t in SUITE.tasks if t.env_id == FLUIDS_ID)
    seeds = [int(s) for s in next(iter(task.eval_sets(SUITE.episodes)))[2][: args.episodes]]
    payload = {
        "env_id": FLUIDS_ID,
        "env_kwargs": dict(task.env_kwargs),
        "episodes": len(seeds),
        "seeds": {"split": "test", "first": seeds[0], "count": len(seeds)},
        "policies": {p: measure(p, seeds, args.batches) for p in args.policies},
    }
    emit(payload, args)
    if not all(v["rows_equal"] for p in payload["policies"].values() for v in p["vector"].values()):
        raise SystemExit("the vector path's rows differ from the scalar path's")


if __name__ == "__main__":
    main()
