"""Measure the locomotion supervisors: return over seeded 1,000-step episodes, falls, ms per label.

Each episode: ``gym.make(<id>, supervisor=<kind>)``, ``reset(seed=s)``, then the supervisor's
label is executed every step (with ``--noise-std`` > 0: label + N(0, std^2 I), clipped, which
is how noise-injection methods collect). One JSON record per (id, kind, noise, seed) is
appended to ``--out`` as it finishes, so a killed run resumes where it stopped. Prints a
Markdown table and writes the results file the docs read (``--results``, default
``docs/results/locomotion_supervisor_quality.json``, atomically: the command line, seeds,
settings, one summary row per (id, supervisor, noise) and the shipped policies' training records
from ``weights/manifest.json``).

Example: ``nice -n 10 python scripts/quality/locomotion_supervisor_quality.py --env Hopper-IL-v0
Walker2d-IL-v0 HalfCheetah-IL-v0 Humanoid-IL-v0 --episodes 10 --noise-std 0 0.02 0.05 0.1 0.3``
(a policy-supervised 1,000-step episode costs about 0.3 CPU-s; an MPC one minutes).

A candidate policy (a training run's ``--out`` file) is measured in place of the shipped one
with ``--weights Humanoid=/path/humanoid.npz``; its records carry its sha256, so they never
mix with the shipped policy's in ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm import tqdm

from fluids_bench.core.parallel import as_finished
from fluids_bench.core.provenance import command_line, machine

SOURCE = {"Hopper": 3571.0, "Walker2d": 6717.0, "HalfCheetah": 4463.0, "Humanoid": 9575.0}
ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "docs" / "results" / "locomotion_supervisor_quality.json"
CPU_SECONDS_PER_EPISODE = {"policy": 0.3, "mpc": 600.0, "guided_mpc": 300.0}  # 1,000 steps
# What a teacher for noise-injection methods must keep under executed-action noise N(0, s^2 I):
# a share of its clean mean return and, where no_falls, no episode ending in a fall (for
# HalfCheetah, which never terminates: no step on its back); falls are shown at every level
NOISE_TARGETS = [
    {"noise_std": 0.05, "min_share_of_clean": 0.9, "no_falls": True},
    {"noise_std": 0.1, "min_share_of_clean": 0.8, "no_falls": False},
]


def summarise(records: list[dict]) -> list[dict]:
    """One row per (id, supervisor, mpc settings, noise): returns, falls, time on its back."""
    groups: dict[tuple, list[dict]] = {}
    for r in records:
        groups.setdefault(
            (r["env_id"], r["kind"], json.dumps(r["mpc"], sort_keys=True), r["noise_std"]), []
        ).append(r)
    rows = []
    for (env_id, kind, mpc, noise), rs in sorted(groups.items()):
        rs = sorted(rs, key=lambda r: r["seed"])
        ret = np.array([r["return"] for r in rs])
        fell = [r for r in rs if r["fell"]]
        rows.append(
            {
                "env_id": env_id,
                "kind": kind,
                "mpc": json.loads(mpc),
                "noise_std": noise,
                "episodes": len(rs),
                "seeds": [r["seed"] for r in rs],
                "mean_return": round(float(ret.mean()), 1),
                "std_return": round(float(ret.std()), 1),
                "min_return": round(float(ret.min()), 1),
                "falls": len(fell),
                "fall_steps": [r["steps"] for r in fell],
                "flipped_share": round(float(np.mean([r["flipped_frac"] for r in rs])), 4),
                "ms_per_label": round(float(np.median([r["ms_per_label"] for r in rs])), 4),
                "source_expert": SOURCE[env_id.split("-")[0]],
            }
        )
    return rows


def _stages(recipe: dict, keep: tuple[str, ...]) -> list[dict]:
    """The training stages that led to a recipe, the first first: each one's settings and how
    it started ("from": None for a run from zero, "checkpoint" for ``--init``, "weights" for
    ``--init-weights``; "started_at_iteration": the iteration it took over at)."""
    chain, stage = [], recipe
    while stage is not None:
        init = stage.get("init")
        chain.append(
            {
                "recipe": {k: stage[k] for k in keep if k in stage},
                "from": None if not init else ("weights" if "weights" in init else "checkpoint"),
                "started_at_iteration": init.get("iteration") if init else None,
            }
        )
        stage = init.get("recipe") if init else None
    return chain[::-1]


def shipped() -> dict:
    """The shipped policies' training records, from the package's weights manifest."""
    path = ROOT / "fluids_bench" / "tasks" / "locomotion" / "weights" / "manifest.json"
    keep = ("n_directions", "top", "step_size", "noise", "shift", "hidden", "seed", "obs_dims")
    keep += ("action_noise", "paired_seeds")
    out = {}
    for name, entry in json.loads(path.read_text()).items():
        out[name] = {
            "file": entry["file"],
            "sha256": entry["sha256"],
            "selected_at_iteration": entry["selected_at_iteration"],
            "training_env_steps": entry["training_env_steps"],
            "training_eval_mean_return": round(entry["training_eval"]["mean_return"], 1),
            "training_eval_episodes": len(entry["training_eval"]["steps"]),
            "stages": _stages(entry["recipe"], keep),
        }
    return out


def parse_weights(items: list[str]) -> dict[str, tuple[str, str]]:
    """``TASK=PATH`` items -> {task: (path, sha256)}; the error names the bad item."""
    from fluids_bench.tasks.locomotion.policy import sha256_of

    out = {}
    for item in items:
        task, sep, path = item.partition("=")
        if not sep or task not in SOURCE or not Path(path).is_file():
            raise ValueError(
                f"--weights {item!r}: allowed: TASK=PATH with TASK one of {sorted(SOURCE)} "
                "and PATH an existing policy file (a training run's --out)"
            )
        out[task] = (str(Path(path).resolve()), sha256_of(path))
    return out


def episode(
    env_id: str,
    kind: str,
    noise_std: float,
    seed: int,
    steps: int,
    mpc: dict | None,
    weights: tuple[str, str] | None = None,
) -> dict:
    import fluids_bench  # noqa: F401  (registers the ids in the worker)

    kwargs = {"supervisor": kind} if mpc is None else {"supervisor": kind, "mpc": mpc}
    if weights is not None:
        kwargs |= {"weights": weights[0], "weights_sha256": weights[1]}
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
        "weights_sha256": None if weights is None else weights[1],
        "return": total,
        "steps": n,
        "fell": bool(terminated),
        "flipped_frac": flipped / max(n, 1),
        "ms_per_label": 1e3 * label_time,
        "supervisor": env.unwrapped.metadata["supervisor"],
    }


def key(r: dict) -> tuple:
    mpc = json.dumps(r["mpc"], sort_keys=True)
    return (r["env_id"], r["kind"], r["noise_std"], r["seed"], mpc, r.get("weights_sha256"))


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
    p.add_argument(
        "--weights",
        nargs="+",
        default=[],
        metavar="TASK=PATH",
        help="measure this policy file instead of the shipped one, e.g. Humanoid=run/humanoid.npz",
    )
    p.add_argument("--out", type=Path, default=Path("out/locomotion_quality.jsonl"))
    p.add_argument(
        "--results", type=Path, default=RESULTS, help="the results file the docs read (JSON)"
    )
    args = p.parse_args(argv)
    if args.episodes < 1 or args.workers < 1 or args.steps < 1 or min(args.noise_std) < 0:
        p.error("--episodes, --workers and --steps >= 1, --noise-std >= 0")
    try:
        weights = parse_weights(args.weights)
    except ValueError as err:
        p.error(str(err))
    if weights and args.results.resolve() == RESULTS:
        p.error(
            "--weights measures a candidate: name its own --results file (the default is "
            "the docs' table of the shipped policies)"
        )
    import fluids_bench  # noqa: F401
    from fluids_bench.algos.results import write_json_atomic
    from fluids_bench.tasks.locomotion.env import DEFAULT_SUPERVISOR

    kinds = [args.kind or DEFAULT_SUPERVISOR[e.split("-")[0]] for e in args.env]
    expected = sum(CPU_SECONDS_PER_EPISODE.get(k, 600.0) for k in kinds)
    expected *= args.episodes * len(args.noise_std) * args.steps / 1000 / args.workers
    print(f"expected run time: ~{max(1, round(expected / 60))} min on {args.workers} free core(s)")
    machine_at_start = machine()
    start = time.perf_counter()

    args.out.parent.mkdir(parents=True, exist_ok=True)
    done = {}
    if args.out.exists():
        for line in args.out.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                done[key(r)] = r

    def candidate(env_id: str) -> tuple[str, str] | None:
        return weights.get(env_id.split("-")[0])

    jobs = []
    for env_id in args.env:
        kind = args.kind or DEFAULT_SUPERVISOR[env_id.split("-")[0]]
        mine_w = candidate(env_id)
        for noise in args.noise_std:
            for seed in range(args.first_seed, args.first_seed + args.episodes):
                probe = {
                    "env_id": env_id,
                    "kind": kind,
                    "noise_std": noise,
                    "seed": seed,
                    "mpc": args.mpc,
                    "weights_sha256": None if mine_w is None else mine_w[1],
                }
                if key(probe) not in done:
                    jobs.append((env_id, kind, noise, seed, args.steps, args.mpc, mine_w))
    with open(args.out, "a") as f:
        for _, r in tqdm(
            as_finished(episode, jobs, args.workers), total=len(jobs), desc="episodes"
        ):
            f.write(json.dumps(r) + "\n")
            f.flush()
            os.fsync(f.fileno())
            done[key(r)] = r
    wanted = {(e, k) for e in args.env for k in [args.kind or DEFAULT_SUPERVISOR[e.split("-")[0]]]}
    seeds = set(range(args.first_seed, args.first_seed + args.episodes))
    mine = [
        r
        for r in done.values()
        if (r["env_id"], r["kind"]) in wanted
        and r["noise_std"] in args.noise_std
        and r["seed"] in seeds
        and r["mpc"] == args.mpc
        and r.get("weights_sha256") == (candidate(r["env_id"]) or (None, None))[1]
    ]
    print(table(mine))
    report = {
        "command": command_line(),
        "envs": args.env,
        "seeds": f"{args.first_seed}-{args.first_seed + args.episodes - 1}",
        "episodes": args.episodes,
        "steps": args.steps,
        "noise_levels": args.noise_std,
        "noise": "executed = clip(label + N(0, std^2 I), low, high); the label is kept",
        "workers": args.workers,
        "machine": machine_at_start,
        "seconds": round(time.perf_counter() - start, 1),
        "rows": summarise(mine),
        "noise_targets": NOISE_TARGETS,
        "shipped": shipped(),
        "weights": {t: {"path": w[0], "sha256": w[1]} for t, w in weights.items()},
    }
    args.results.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.results, report)
    print(f"wrote {args.results}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
