"""Measure the locomotion supervisors: return over seeded 1,000-step episodes, falls, ms per label.

Each episode: ``gym.make(<id>, supervisor=<kind>)``, ``reset(seed=s)``, then the supervisor's
label is executed every step (with ``--noise-std`` > 0: label + N(0, std^2 I), clipped, which
is how noise-injection methods collect). One JSON record per (id, kind, noise, seed) is
appended to ``--out`` as it finishes, so a killed run resumes where it stopped. Prints the
Markdown table of the README.

Example: ``nice -n 10 python scripts/quality/locomotion_supervisor_quality.py --env HalfCheetah-IL-v0
--kind mpc --episodes 10 --workers 2``
"""

from __future__ import annotations

import argparse
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm import tqdm

SOURCE = {"Hopper": 3571.0, "Walker2d": 6717.0, "HalfCheetah": 4463.0, "Humanoid": 9575.0}


def episode(
    env_id: str, kind: str, noise_std: float, seed: int, steps: int, mpc: dict | None
) -> dict:
    import fluids_bench  # noqa: F401  (registers the ids in the worker)

    kwargs = {"supervisor": kind} if mpc is None else {"supervisor": kind, "mpc": mpc}
    env = gym.make(env_id, max_episode_steps=steps, **kwargs)
    rng = np.random.default_rng([seed, 0xA5])
    _, info = env.reset(seed=seed)
    total, n, flipped = 0.0, 0, 0
    planar = not env_id.startswith("Humanoid")
    terminated = truncated = False
    while not (terminated or truncated):
        label = info["supervisor_action"]
        action = label + noise_std * rng.standard_normal(label.shape) if noise_std else label
        action = np.clip(action, env.action_space.low, env.action_space.high)
        _, reward, terminated, truncated, info = env.step(action)
        total += reward
        n += 1
        # planar bodies: qpos[2] is the torso pitch; beyond pi/2 the runner is on its back
        flipped += planar and abs(env.unwrapped._sim.data.qpos[2]) > np.pi / 2
    # time the label alone on the final state (the step loop above includes physics)
    t0 = time.perf_counter()
    reps = 20 if kind == "policy" else 3
    for _ in range(reps):
        env.unwrapped.supervisor_action()
    label_time = (time.perf_counter() - t0) / reps
    return {
        "env_id": env_id,
        "kind": kind,
        "noise_std": noise_std,
        "seed": seed,
        "mpc": mpc,
        "return": total,
        "steps": n,
        "fell": bool(terminated),
        "flipped_frac": flipped / max(n, 1),
        "ms_per_label": 1e3 * label_time,
        "supervisor": env.unwrapped.metadata["supervisor"],
    }


def key(r: dict) -> tuple:
    return (r["env_id"], r["kind"], r["noise_std"], r["seed"], json.dumps(r["mpc"], sort_keys=True))


def table(records: list[dict]) -> str:
    groups: dict[tuple, list[dict]] = {}
    for r in records:
        groups.setdefault(
            (r["env_id"], r["kind"], r["noise_std"], json.dumps(r["mpc"])), []
        ).append(r)
    lines = [
        "| env | supervisor | noise std | episodes | mean return ± sd | min | falls | steps on its back | source expert | ms/label |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for (env_id, kind, noise, mpc), rs in sorted(groups.items()):
        ret = np.array([r["return"] for r in rs])
        name = env_id.split("-")[0]
        label = kind if mpc == "null" else f"{kind} {mpc}"
        lines.append(
            f"| {env_id} | {label} | {noise:g} | {len(rs)} | {ret.mean():,.0f} ± {ret.std():,.0f} | "
            f"{ret.min():,.0f} | {sum(r['fell'] for r in rs)} | "
            f"{100 * np.mean([r.get('flipped_frac', 0.0) for r in rs]):.1f}% | {SOURCE[name]:,.0f} | "
            f"{np.median([r['ms_per_label'] for r in rs]):.2f} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", nargs="+", required=True)
    p.add_argument("--kind", default=None, help="policy, mpc or guided_mpc (default: the id's)")
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--first-seed", type=int, default=0)
    p.add_argument("--steps", type=int, default=1000)
    p.add_argument("--noise-std", type=float, nargs="+", default=[0.0])
    p.add_argument("--mpc", type=json.loads, default=None, help="planner overrides, JSON")
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--out", type=Path, default=Path("runs/locomotion_quality.jsonl"))
    args = p.parse_args(argv)
    import fluids_bench  # noqa: F401
    from fluids_bench.tasks.locomotion.env import DEFAULT_SUPERVISOR

    args.out.parent.mkdir(parents=True, exist_ok=True)
    done = {}
    if args.out.exists():
        for line in args.out.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                done[key(r)] = r
    jobs = []
    for env_id in args.env:
        kind = args.kind or DEFAULT_SUPERVISOR[env_id.split("-")[0]]
        for noise in args.noise_std:
            for seed in range(args.first_seed, args.first_seed + args.episodes):
                probe = {
                    "env_id": env_id,
                    "kind": kind,
                    "noise_std": noise,
                    "seed": seed,
                    "mpc": args.mpc,
                }
                if key(probe) not in done:
                    jobs.append((env_id, kind, noise, seed, args.steps, args.mpc))
    with ProcessPoolExecutor(args.workers) as pool, open(args.out, "a") as f:
        futures = [pool.submit(episode, *job) for job in jobs]
        for fut in tqdm(as_completed(futures), total=len(futures), desc="episodes"):
            r = fut.result()
            f.write(json.dumps(r) + "\n")
            f.flush()
            os.fsync(f.fileno())
            done[key(r)] = r
    wanted = {(e, k) for e in args.env for k in [args.kind or DEFAULT_SUPERVISOR[e.split("-")[0]]]}
    print(table([r for r in done.values() if (r["env_id"], r["kind"]) in wanted]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
