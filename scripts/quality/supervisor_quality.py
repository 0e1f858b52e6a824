"""Supervisor quality table: success rate of fully supervised FLUIDS episodes, as JSON + Markdown.

For every scene of ``--cars`` × ``--peds`` on ``--layout``, runs ``--episodes`` seeded episodes in
which the supervisor drives every agent until all have arrived. An episode succeeds when every
agent reaches its goal with no collision; one that runs out of steps without a collision is a
deadlock. Usage: ``python scripts/quality/supervisor_quality.py --layout four_way --episodes 200``.
Several layouts may be given (the default is all three). With ``--results FILE`` (e.g.
``docs/results/fluids_supervisor_quality.json``) the report of every layout, the command and its
settings are written to FILE atomically; the docs' supervisor quality table reads it.

With ``--out FILE``, each scene's row is appended to ``FILE.jsonl`` as soon as it finishes, and a
rerun skips the scenes already there: a killed run resumes where it stopped.

With ``--env ID`` (a benchmark id with a driving score, e.g. ``FLUIDS-v4``) it measures that id's
ego supervisor instead, over the first ``--episodes`` seeds of ``--split`` (the benchmark's
splits, ``fluids_bench.core.splits``), in each of ``--conditions``:

* ``supervisor``: the ego executes its label;
* ``noisy``: the label plus N(0, ``--noise``²) on every action entry (normalised units;
  ``fluids_bench.algos.actors.NoisySupervisorActor``), clipped;
* ``background``: the id's PettingZoo face with 3 more controlled cars in place of the
  background cars (same scene otherwise): they execute their labels plus
  N(0, ``--background-noise``²), so they do not follow the plan; the ego's supervisor drives
  defensively toward them, as the background drives toward the ego. The ego executes its label.

Per condition: success (Wilson 95 % interval), mean driving score and route completion (95 %
bootstrap intervals, ``fluids_bench.benchmark.metrics.interval``), each infraction's count, the
failed seeds. ``--out FILE``: one row per finished episode in ``FILE.jsonl`` (resumable);
``--results FILE``: the summary, command and settings, written atomically.

    python scripts/quality/supervisor_quality.py --env FLUIDS-v4 --episodes 200 \\
        --out runs/sq_v4 --results docs/results/fluids_v4_supervisor_quality.json
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import shlex
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed

from tqdm import tqdm

from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.jsonl import read_rows
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import relative_paths
from fluids_bench.tasks.fluids.sim.config import SceneConfig
from fluids_bench.tasks.fluids.supervisor.episode import run_supervised


def _command() -> str:
    """This run's command line, as a results file records it (relative paths)."""
    args = " ".join(shlex.quote(a) for a in relative_paths(sys.argv[1:]))
    return f"python scripts/quality/supervisor_quality.py {args}"


def _machine() -> dict:
    """The machine a results file was measured on."""
    return {"processor": platform.processor() or platform.machine(), "cpu_count": os.cpu_count()}


def _scene_result(args: tuple[str, int, int, int, int]) -> dict:
    layout, cars, peds, episodes, max_steps = args
    scene = SceneConfig(layout=layout, num_cars=cars, num_pedestrians=peds)
    t0 = time.process_time()
    results = [run_supervised(scene, seed, max_steps=max_steps) for seed in range(episodes)]
    return {
        "layout": layout,
        "cars": cars,
        "pedestrians": peds,
        "episodes": episodes,
        "success": sum(r.success for r in results),
        "collision_episodes": sum(r.collisions > 0 for r in results),
        "deadlocks": sum(r.timed_out for r in results),
        "failed_seeds": [r.seed for r in results if not r.success],
        "steps": sum(r.steps for r in results),
        "cpu_seconds": round(time.process_time() - t0, 2),
    }


def main() -> None:
    if "--env" in sys.argv:
        return env_main()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--layout",
        nargs="+",
        default=["four_way", "t_junction", "roundabout"],
        choices=["four_way", "t_junction", "roundabout"],
    )
    parser.add_argument("--cars", type=int, nargs=2, default=(2, 7), metavar=("MIN", "MAX"))
    parser.add_argument("--peds", type=int, nargs=2, default=(0, 4), metavar=("MIN", "MAX"))
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument(
        "--max-steps", type=int, default=1500, help="steps before a deadlock is declared"
    )
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", default=None, help="JSON file to write (atomically)")
    parser.add_argument(
        "--results",
        default=None,
        help="results file for the docs (all layouts, the command and settings), written atomically",
    )
    args = parser.parse_args()
    scenes = (args.cars[1] - args.cars[0] + 1) * (args.peds[1] - args.peds[0] + 1)
    minutes = 0.0008 * scenes * args.episodes * len(args.layout) / max(1, min(args.workers, 2))
    print(f"expected run time: ~{max(1, round(minutes))} min on 2 cores", flush=True)
    started = time.time()
    reports = [_run_layout(args, layout) for layout in args.layout]
    if args.results:
        write_json_atomic(
            args.results,
            {
                "command": _command(),
                "settings": {
                    "cars": list(args.cars),
                    "pedestrians": list(args.peds),
                    "episodes_per_scene": args.episodes,
                    "seeds": f"0..{args.episodes - 1} per scene",
                    "max_steps": args.max_steps,
                    "workers": args.workers,
                },
                "machine": _machine(),
                "wall_seconds": round(time.time() - started, 1),
                "layouts": reports,
            },
        )


def _run_layout(args: argparse.Namespace, layout: str) -> dict:
    jobs = [
        (layout, c, p, args.episodes, args.max_steps)
        for c in range(args.cars[0], args.cars[1] + 1)
        for p in range(args.peds[0], args.peds[1] + 1)
    ]
    out = None
    if args.out:
        out = args.out if len(args.layout) == 1 else f"{args.out}.{layout}"
    log = f"{out}.jsonl" if out else None
    done = {(r["layout"], r["cars"], r["pedestrians"], r["episodes"]): r for r in read_rows(log)}
    todo = [j for j in jobs if j[:4] not in done]
    with ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool:
        futures = [pool.submit(_scene_result, job) for job in todo]
        for future in tqdm(as_completed(futures), total=len(futures), desc=layout, unit="scene"):
            row = future.result()
            done[(row["layout"], row["cars"], row["pedestrians"], row["episodes"])] = row
            if log:
                with open(log, "a") as f:
                    f.write(json.dumps(row) + "\n")
                    f.flush()
                    os.fsync(f.fileno())
    rows = [done[j[:4]] for j in jobs]
    total = sum(r["episodes"] for r in rows)
    report = {
        "layout": layout,
        "episodes": total,
        "collision_episodes": sum(r["collision_episodes"] for r in rows),
        "deadlocks": sum(r["deadlocks"] for r in rows),
        "success_rate": sum(r["success"] for r in rows) / total,
        "scenes": rows,
    }
    text = json.dumps(report, indent=2)
    if out:
        tmp = f"{out}.tmp"
        with open(tmp, "w") as f:
            f.write(text)
        os.replace(tmp, out)
    print(text)
    print(
        "\n| cars \\ peds | "
        + " | ".join(str(p) for p in range(args.peds[0], args.peds[1] + 1))
        + " |"
    )
    print("|---" * (args.peds[1] - args.peds[0] + 2) + "|")
    for c in range(args.cars[0], args.cars[1] + 1):
        cells = [f"{r['success']}/{r['episodes']}" for r in rows if r["cars"] == c]
        print(f"| {c} | " + " | ".join(cells) + " |")
    return report


# ------------------------------------------------------------------ --env: a benchmark id's ego

CONDITIONS = ("supervisor", "noisy", "background")
EXTRA_CONTROLLED = 3  # the `background` condition's controlled cars besides the ego


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a rate (95 % at z = 1.96)."""
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def _ego_row(condition: str, seed: int, info: dict, steps: int) -> dict:
    return {
        "condition": condition,
        "seed": seed,
        "success": bool(info.get("is_success", False)),
        "driving_score": float(info["driving_score"]),
        "route_completion": float(info["route_completion"]),
        "infractions": {k: int(v) for k, v in info["infractions"].items()},
        "steps": steps,
    }


def _single(env_id: str, condition: str, seed: int, noise: float) -> dict:
    import gymnasium as gym
    import numpy as np

    from fluids_bench.algos.actors import SUPERVISOR, NoisySupervisorActor
    from fluids_bench.algos.rollout import rollout

    env = gym.make(env_id)
    actor = SUPERVISOR
    if condition == "noisy":
        dim = int(np.prod(env.action_space.shape))
        actor = NoisySupervisorActor(env.action_space, covariance=noise**2 * np.eye(dim))
    trajectory = rollout(env, actor, seed)
    env.close()
    return _ego_row(condition, seed, trajectory.infos[-1], len(trajectory))


def _background(env_id: str, seed: int, noise: float) -> dict:
    """The ego (car_0) on its label among `EXTRA_CONTROLLED` controlled cars that execute
    theirs plus noise; the episode ends with the ego's."""
    import gymnasium as gym
    import numpy as np

    from fluids_bench.algos.rollout import actor_rng
    from fluids_bench.registration import ENV_SPECS, make_parallel_env

    _, steps, kwargs = ENV_SPECS[env_id]
    if kwargs.get("action_level") != "trajectory":
        raise SystemExit(f"--conditions background: {env_id} is not a trajectory-level id")
    scene = {k: v for k, v in kwargs.items() if k not in ("obey_lights", "time_limit")}
    scene["controlled_cars"] = 1 + EXTRA_CONTROLLED
    scene["num_cars"] = kwargs.get("num_cars", 3) - EXTRA_CONTROLLED
    env = make_parallel_env(
        env_id.replace("FLUIDS-", "FLUIDS-MultiAgent-"), max_cycles=steps, **scene
    )
    rng = actor_rng(seed)
    _, infos = env.reset(seed=seed)
    ego, count = "car_0", 0
    while True:
        actions = {}
        for agent in env.agents:
            label = np.asarray(infos[agent]["supervisor_action"], dtype=np.float64)
            if agent != ego:
                label = label + noise * rng.standard_normal(label.shape)
            space = env.action_space(agent)
            actions[agent] = np.clip(label, space.low, space.high).astype(space.dtype)
        _, _, terminations, truncations, infos = env.step(actions)
        count += 1
        if terminations.get(ego) or truncations.get(ego):
            row = _ego_row("background", seed, infos[ego], count)
            env.close()
            return row
        if ego not in env.agents:  # pragma: no cover - the env reports the ego's end above
            raise RuntimeError(f"seed {seed}: the ego left without a last info")
    del gym


def _episode(job: tuple[str, str, int, float, float]) -> dict:
    env_id, condition, seed, noise, background_noise = job
    if condition == "background":
        return _background(env_id, seed, background_noise)
    return _single(env_id, condition, seed, noise)


def summarise(rows: list[dict]) -> dict:
    """Success with its Wilson interval; driving score and route completion means with their
    bootstrap intervals; total and per-episode infraction counts; failed seeds."""
    from fluids_bench.benchmark.metrics import interval

    n = len(rows)
    wins = sum(r["success"] for r in rows)
    out = {"episodes": n, "success": wins, "success_rate": wins / n, "success_ci": wilson(wins, n)}
    for key in ("driving_score", "route_completion"):
        mean, low, high = interval([r[key] for r in rows])
        out[key] = mean
        out[f"{key}_ci"] = [low, high]
    names = rows[0]["infractions"]
    out["infractions"] = {k: sum(r["infractions"][k] for r in rows) for k in names}
    out["failed_seeds"] = [r["seed"] for r in rows if not r["success"]]
    return out


def env_main() -> None:
    from fluids_bench.core.splits import split_seeds

    parser = argparse.ArgumentParser(description="a benchmark id's ego supervisor (see --help)")
    parser.add_argument("--env", required=True, help="a benchmark id, e.g. FLUIDS-v4")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--split", default="validation", choices=["validation", "train"])
    parser.add_argument("--conditions", nargs="+", default=list(CONDITIONS), choices=CONDITIONS)
    parser.add_argument("--noise", type=float, default=0.02, help="ego action noise std")
    parser.add_argument("--background-noise", type=float, default=0.1)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", default=None, help="rows in OUT.jsonl (resumable)")
    parser.add_argument("--results", default=None, help="summary JSON (written atomically)")
    args = parser.parse_args()
    seeds = split_seeds(args.split, args.episodes)
    print(f"expected run time: ~{round(0.03 * args.episodes * len(args.conditions))} min on one "
          "core", flush=True)  # fmt: skip
    started = time.time()
    log = f"{args.out}.jsonl" if args.out else None
    done = {(r["condition"], r["seed"]): r for r in read_rows(log)}
    jobs = [
        (args.env, c, s, args.noise, args.background_noise)
        for c in args.conditions
        for s in seeds
        if (c, s) not in done
    ]
    with ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool:
        futures = [pool.submit(_episode, job) for job in jobs]
        for future in tqdm(as_completed(futures), total=len(futures), unit="episode"):
            row = future.result()
            done[row["condition"], row["seed"]] = row
            if log:
                with open(log, "a") as f:
                    f.write(json.dumps(row) + "\n")
                    f.flush()
                    os.fsync(f.fileno())
    report = {c: summarise([done[c, s] for s in seeds]) for c in args.conditions}
    print(json.dumps(report, indent=1))
    if args.results:
        write_json_atomic(
            args.results,
            {
                "command": _command(),
                "settings": {
                    "env": args.env,
                    "split": args.split,
                    "seeds": f"{seeds[0]}..{seeds[-1]}",
                    "episodes": args.episodes,
                    "noise": args.noise,
                    "background_noise": args.background_noise,
                    "background_controlled_cars": EXTRA_CONTROLLED,
                    "workers": args.workers,
                },
                "machine": _machine(),
                "wall_seconds": round(time.time() - started, 1),
                "conditions": report,
            },
        )


if __name__ == "__main__":
    main()
