"""Peer environments' step rate next to FLUIDS', measured by one script in one process, as JSON.

Every env is stepped the same way: `gym.make`, a warm-up (a reset and a few steps: imports,
compiled kernels, first plans), then `--repeats` rounds of `--steps` env steps each (the peers'
counts scaled down: they are slower), episodes restarting with the next seed whenever they
end. Only `env.step` is timed (resets are not: CarRacing builds its track there). Each round's rate is steps per CPU-second of this process
(`time.process_time`, less sensitive than the wall clock to the other jobs on a shared machine)
and steps per wall second; the table shows the median round and the spread (min-max) over rounds.

What acts:

* `FLUIDS-v1`, `FLUIDS-v4`, `DrivingTrack-v0`: their supervisor (the executed action is
  `info["supervisor_action"]`, so the label is computed every step, as in collection);
* highway-env's `intersection-v0`: random meta-actions, with `simulation_frequency=10` and
  `policy_frequency=10`, so that one env step is one 0.1 s simulator step as in FLUIDS
  (its defaults are 15 Hz and 1 Hz: one env step of 1 s in 15 simulator steps);
* Gymnasium's `CarRacing-v3` (Box2D) and gym-pusht's `gym_pusht/PushT-v0` (`obs_type="state"`):
  random actions.

The peers are not dependencies of fluids-bench: install them in their own virtual environment,
which sees the system's packages for fluids-bench itself (gym-pusht pins pymunk < 7, which
Singulation-v0 cannot use, so Singulation is not in this run)::

    python3 -m venv --system-site-packages venv-peers
    venv-peers/bin/pip install highway-env "gymnasium[box2d]" gym-pusht
    PYTHONPATH=. venv-peers/bin/python scripts/benchmarks/bench_peers.py \
        --results docs/results/bench_peers.json

A peer that does not import is recorded with the error (`"unavailable"`) instead of a rate. The
original FLUIDS (BerkeleyAutomation's) is not on PyPI: the PyPI name `fluids` belongs to another
project (the Chemical Engineering Design Library's fluid-dynamics package), so it is recorded as
unavailable with that reason. About two minutes on one loaded core.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.metadata
import statistics
import sys
import time
import traceback
from typing import Any

import gymnasium as gym
from _results import add_results_option, emit

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core.provenance import announce

# name -> (id, kwargs, who acts, the module that registers it, its PyPI distribution, share of
# --steps: the slow peers run fewer steps per round so the whole run stays short)
ENVS: dict[str, dict[str, Any]] = {
    "FLUIDS-v1": {"id": "FLUIDS-v1", "policy": "supervisor", "dist": "fluids-bench"},
    "FLUIDS-v4": {"id": "FLUIDS-v4", "policy": "supervisor", "dist": "fluids-bench"},
    "DrivingTrack-v0": {"id": "DrivingTrack-v0", "policy": "supervisor", "dist": "fluids-bench"},
    "highway-env intersection-v0": {
        "id": "intersection-v0",
        "kwargs": {"config": {"simulation_frequency": 10, "policy_frequency": 10}},
        "policy": "random",
        "module": "highway_env",
        "dist": "highway-env",
        "share": 0.05,
    },
    "Gymnasium CarRacing-v3": {
        "id": "CarRacing-v3",
        "policy": "random",
        "module": "Box2D",
        "dist": "box2d",
        "share": 0.1,
    },
    "gym-pusht PushT-v0": {
        "id": "gym_pusht/PushT-v0",
        "kwargs": {"obs_type": "state"},
        "policy": "random",
        "module": "gym_pusht",
        "dist": "gym-pusht",
        "share": 0.3,
    },
}
ORIGINAL_FLUIDS = (
    "not installable from PyPI: the PyPI name `fluids` is the Chemical Engineering Design "
    "Library's fluid-dynamics package, not BerkeleyAutomation's FLUIDS, which installs only "
    "from its git repository (not reachable from the machine that ran this)"
)


def _version(dist: str) -> str | None:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return None


def _round(env, policy: str, steps: int, seed: int) -> tuple[int, float, float, int]:
    """`steps` env steps from a reset with `seed`; (next seed, CPU s, wall s, episodes), the
    resets' own time left out (CarRacing builds a track there, FLUIDS a scene)."""
    episodes = done = 0
    cpu = wall = 0.0
    while done < steps:
        _, info = env.reset(seed=seed)
        seed += 1
        episodes += 1
        ended = False
        c0, t0 = time.process_time(), time.perf_counter()
        while not ended and done < steps:
            action = (
                info["supervisor_action"] if policy == "supervisor" else env.action_space.sample()
            )
            _, _, terminated, truncated, info = env.step(action)
            ended = terminated or truncated
            done += 1
        cpu += time.process_time() - c0
        wall += time.perf_counter() - t0
    return seed, cpu, wall, episodes


def measure(spec: dict[str, Any], steps: int, repeats: int) -> dict[str, Any]:
    env = gym.make(spec["id"], **spec.get("kwargs", {}))
    env.action_space.seed(0)
    _, info = env.reset(seed=10**6)  # warm-up: imports, compiled kernels, first plans
    for _ in range(5):
        action = (
            info["supervisor_action"]
            if spec["policy"] == "supervisor"
            else env.action_space.sample()
        )
        _, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    n = max(10, int(steps * spec.get("share", 1.0)))
    seed, cpu_rates, wall_rates, episodes = 0, [], [], 0
    for _ in range(repeats):
        seed, cpu, wall, eps = _round(env, spec["policy"], n, seed)
        cpu_rates.append(n / cpu)
        wall_rates.append(n / wall)
        episodes += eps
    env.close()
    return {
        "id": spec["id"],
        "kwargs": spec.get("kwargs", {}),
        "policy": spec["policy"],
        "steps_per_round": n,
        "rounds": repeats,
        "episodes": episodes,
        "steps_per_cpu_s": [round(r, 1) for r in cpu_rates],
        "steps_per_s": [round(r, 1) for r in wall_rates],
        "median_steps_per_cpu_s": round(statistics.median(cpu_rates), 1),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=1500, help="FLUIDS steps per round")
    parser.add_argument("--repeats", type=int, default=3, help="rounds per env")
    parser.add_argument("--only", nargs="+", choices=list(ENVS), default=list(ENVS))
    add_results_option(parser)
    args = parser.parse_args(argv)
    if args.steps < 10 or args.repeats < 1:
        parser.error(f"--steps is {args.steps}, --repeats {args.repeats}; allowed: >= 10, >= 1")
    announce("about two minutes on one loaded core (FLUIDS compiles its kernels on a first run)")
    results: dict[str, Any] = {}
    versions = {"fluids-bench": _version("fluids-bench"), "gymnasium": gym.__version__}
    for name in args.only:
        spec = ENVS[name]
        try:
            if "module" in spec:
                importlib.import_module(spec["module"])
            if spec["dist"] != "fluids-bench":
                versions[spec["dist"]] = _version(spec["dist"])
            results[name] = measure(spec, args.steps, args.repeats)
        except Exception as exc:  # a peer that does not install or run is recorded, not fatal
            traceback.print_exc(file=sys.stderr)
            results[name] = {"id": spec["id"], "unavailable": f"{type(exc).__name__}: {exc}"}
        print(f"{name}: {results[name]}", file=sys.stderr, flush=True)
    results["original FLUIDS"] = {"id": None, "unavailable": ORIGINAL_FLUIDS}
    payload = {
        "benchmark": "bench_peers",
        "steps": args.steps,
        "repeats": args.repeats,
        "versions": versions,
        "python": sys.version.split()[0],
        "environment": (
            "a virtual environment made with --system-site-packages (fluids-bench and its "
            "dependencies from the system) plus the peers: pip install highway-env "
            '"gymnasium[box2d]" gym-pusht (gym-pusht brings pymunk 6.11 into it)'
        ),
        "timing": "env.step only (resets not timed); CPU-seconds of this process per round",
        "results": results,
    }
    emit(payload, args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
