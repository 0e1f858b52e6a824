"""Wall time of one ``fluids-bench train`` run on 1 and 2 workers (and Ray): the speed-up of
running an iteration's rollouts and the evaluation episodes in parallel.

Each run is the real command, a fresh process timed from start to exit (imports, pool or Ray
start-up, rollouts, fits, evaluation, writing the JSON and the plot). Runs alternate between the
settings, ``--repeats`` times, and the median is reported. Every run's records (without timing)
must be identical, which the script checks. Example (the docs' numbers)::

    python scripts/benchmarks/bench_train_scaling.py --ray --results docs/results/train_scaling.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from fluids_bench.core.parallel import descendants

TIMING = ("train_seconds", "wall_seconds")


def train_command(args: argparse.Namespace, out: Path, workers: int, backend: str) -> list[str]:
    kwargs = args.env_kwarg
    if kwargs is None:
        kwargs = ["action_level=velocity"] if args.env.startswith("FLUIDS") else []
    command = ["fluids-bench", "train", "--env", args.env, "--algo", args.algo]
    for kv in kwargs:
        command += ["--env-kwarg", kv]
    command += [
        "--demos-per-iteration", str(args.demos_per_iteration),
        "--iterations", str(args.iterations),
        "--eval-episodes", str(args.eval_episodes),
        "--seed", str(args.seed),
        "--workers", str(workers),
    ]  # fmt: skip
    if backend != "process":
        command += ["--backend", backend]
    return [*command, "--no-progress", "--out", str(out)]


def records(out: Path) -> dict[str, Any]:
    (path,) = out.glob("*.json")
    payload = json.loads(path.read_text())
    for record in payload["records"]:
        for name in TIMING:
            record.pop(name)
    return payload


def _cpu_seconds(pid: int) -> float | None:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime + stime


def run(command: list[str]) -> tuple[float, float]:
    """Wall seconds of the command, and the CPU seconds of it and every process it started
    (workers, fork server, Ray's processes), sampled every 0.25 s: a process's last 0.25 s
    can be missed."""
    env = {**os.environ, "RAY_AUTH_MODE": "disabled"}
    argv = [sys.executable, "-m", "fluids_bench.cli", *command[1:]]
    start = time.perf_counter()
    process = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL)
    cpu: dict[int, float] = {}
    while process.poll() is None:
        for pid in [process.pid, *descendants(process.pid)]:
            seconds = _cpu_seconds(pid)
            if seconds is not None:
                cpu[pid] = seconds
        time.sleep(0.25)
    wall = time.perf_counter() - start
    if process.returncode != 0:
        raise subprocess.CalledProcessError(process.returncode, argv)
    return wall, sum(cpu.values())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", default="FLUIDS-v1")
    parser.add_argument(
        "--env-kwarg",
        action="append",
        default=None,
        help="default for FLUIDS: action_level=velocity",
    )
    parser.add_argument("--algo", default="dagger")
    parser.add_argument("--demos-per-iteration", type=int, default=4)
    parser.add_argument("--iterations", type=int, default=5)
    parser.add_argument("--eval-episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--ray", action="store_true", help="also Ray with the most workers")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--results", type=Path, default=None, help="write the JSON here")
    args = parser.parse_args()
    settings = [(w, "process") for w in args.workers]
    if args.ray:
        settings.append((max(args.workers), "ray"))
    print(
        f"expected run time: ~{1 + args.repeats * len(settings) * 2 // 3} min on 2 cores "
        "(FLUIDS-v1 defaults: ~40 s a run on a loaded machine)",
        flush=True,
    )
    started = time.perf_counter()
    load_before = os.getloadavg()
    times: dict[tuple[int, str], list[float]] = {s: [] for s in settings}
    cpu: dict[tuple[int, str], list[float]] = {s: [] for s in settings}
    outputs: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="train-scaling-") as tmp:
        # warm-up, untimed: compiled kernels cached, files in the page cache
        warm = train_command(args, Path(tmp) / "warm", 1, "process")
        warm[warm.index("--iterations") + 1] = "1"
        warm[warm.index("--eval-episodes") + 1] = "1"
        run(warm)
        for repeat in range(args.repeats):
            for workers, backend in settings:
                out = Path(tmp) / f"{backend}{workers}-{repeat}"
                seconds, cpu_seconds = run(train_command(args, out, workers, backend))
                times[(workers, backend)].append(seconds)
                cpu[(workers, backend)].append(cpu_seconds)
                outputs.append(records(out))
                print(f"{backend} x{workers}: {seconds:.1f} s, {cpu_seconds:.1f} CPU s", flush=True)
    identical = all(o == outputs[0] for o in outputs)
    if not identical:
        raise SystemExit("the records differ between runs: a determinism defect")
    base = statistics.median(times[(1, "process")]) if (1, "process") in times else None
    rows = []
    for (workers, backend), seconds in times.items():
        median = statistics.median(seconds)
        rows.append(
            {
                "workers": workers,
                "backend": backend,
                "seconds": [round(s, 2) for s in seconds],
                "median_seconds": round(median, 2),
                "cpu_seconds": [round(c, 1) for c in cpu[(workers, backend)]],
                "median_cpu_seconds": round(statistics.median(cpu[(workers, backend)]), 1),
                "speedup": None if base is None else round(base / median, 3),
                "command": shlex.join(train_command(args, Path("out/train"), workers, backend)),
            }
        )
    final = outputs[0]["records"][-1]
    payload = {
        "command": shlex.join(["python", *sys.argv]),
        "settings": {
            "env": args.env,
            "algo": args.algo,
            "demos_per_iteration": args.demos_per_iteration,
            "iterations": args.iterations,
            "eval_episodes": args.eval_episodes,
            "repeats": args.repeats,
            "rollouts": outputs[0]["records"][-1]["demonstrations"],
            "evaluation_episodes": args.eval_episodes
            * (1 + sum(r["eval_return"] is not None for r in outputs[0]["records"])),
        },
        "seeds": [args.seed],
        "machine": {
            "cpus": os.cpu_count(),
            "load_average_before": [round(x, 2) for x in load_before],
            "load_average_after": [round(x, 2) for x in os.getloadavg()],
            "python": platform.python_version(),
            "processor": platform.machine(),
        },
        "identical_records": identical,
        "final_normalised_performance": final["normalised_performance"],
        "runs": rows,
        "seconds": round(time.perf_counter() - started, 1),
    }
    text = json.dumps(payload, indent=2)
    print(text)
    if args.results is not None:
        from fluids_bench.algos.results import write_json_atomic

        write_json_atomic(args.results, payload)
        print(f"wrote {args.results}")


if __name__ == "__main__":
    main()
