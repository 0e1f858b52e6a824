"""Learner baselines on FLUIDS at the velocity level: success, collisions by fault, time to goal.

For each env id (``FLUIDS-v1`` with ``action_level="velocity"``, ``FLUIDS-Sensitivity-v1``) and
each method, trains where needed and evaluates over ``--episodes`` seeded episodes (seeds
100000 + i, never used in training):

* ``random``: a uniform target speed in [0, v_max] every step; ``constant``: 5 m/s;
* ``supervisor``: the env's own label;
* ``bc_tree``, ``bc_mlp``: Behavior Cloning on ``--demos`` supervisor episodes (decision tree,
  MLP; :mod:`fluids_bench.algos.bc`);
* ``dagger``, ``dart``: tree learners, ``--demos`` rollouts in all
  (:mod:`fluids_bench.algos.dagger`, :mod:`fluids_bench.algos.dart`);
* ``ppo``: stable-baselines3 PPO for ``--ppo-steps`` env steps (the ``train`` extra; skipped,
  and said so, when it is not installed).

Per method: success rate, episodes with a collision, collisions by fault (the ego's, a
supervised agent's, cut-ins), red-light runs, episodes in which the ego drove onto a
crosswalk with a pedestrian on it (``info["ego_failed_to_yield"]``; in v1 it fails the
episode), timeouts, and mean time to goal (s) of arrived episodes. ``--env-kwargs
'{"num_cars": 15}'`` evaluates a scene variant (rows keep it).
Rows append to ``--out``.jsonl as each (id, method) finishes; a rerun skips them (resumable);
the table is written atomically to ``--out``. ``--workers`` runs (id, method) jobs in parallel.

    python scripts/baselines/fluids_baselines.py --episodes 200 --demos 60 --ppo-steps 100000 --out b.json
"""

from __future__ import annotations

import argparse
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.policies import PolicySpec
from fluids_bench.algos.registry import run_algorithm
from fluids_bench.core.jsonl import read_rows
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import announce

ENVS = {
    "FLUIDS-v1": {"action_level": "velocity"},
    "FLUIDS-Sensitivity-v1": {},
}
METHODS = ("random", "constant", "supervisor", "bc_tree", "bc_mlp", "dagger", "dart", "ppo")
SLOW = ("ppo", "bc_mlp", "dart", "dagger")
EVAL_SEED = 100_000


def _train(method: str, env_id: str, kwargs: dict, demos: int, ppo_steps: int, seed: int):
    """A callable ``(obs, info, rng) -> action``, or None when the method cannot run here."""
    if method == "random":
        return lambda obs, info, rng: rng.uniform(0.0, 10.0, 1).astype(np.float32)
    if method == "constant":
        return lambda obs, info, rng: np.array([5.0], np.float32)
    if method == "supervisor":
        return lambda obs, info, rng: info["supervisor_action"]
    if method == "ppo":
        try:
            from stable_baselines3 import PPO
            from stable_baselines3.common.env_util import make_vec_env
        except ImportError:
            return None
        # "fluids_bench:<id>" imports the package in subprocess workers too
        import torch

        torch.set_num_threads(1)  # the pool's workers share the cores: one thread each
        venv = make_vec_env(f"fluids_bench:{env_id}", n_envs=2, seed=seed, env_kwargs=kwargs)
        model = PPO("MlpPolicy", venv, seed=seed, verbose=0)
        model.learn(total_timesteps=ppo_steps)
        return lambda obs, info, rng: model.predict(obs, deterministic=True)[0]
    common = {
        "env_id": env_id,
        "env_kwargs": kwargs,
        "eval_episodes": 2,
        "eval_every": 10**6,  # the harness evaluates only the final learner; we do our own
        "samples_per_demo": None,
        "seed": seed,
    }
    if method in ("bc_tree", "bc_mlp"):
        spec = PolicySpec("tree" if method == "bc_tree" else "mlp")
        result = run_algorithm("bc", policy=spec, iterations=demos, **common)
    elif method == "dagger":
        result = run_algorithm("dagger", policy=PolicySpec("tree"), iterations=demos - 1, **common)
    else:  # dart
        result = run_algorithm(
            "dart",
            policy=PolicySpec("tree"),
            iterations=demos,
            update_at=(max(2, demos // 4), max(3, demos // 2)),
            heldout_fraction=0.1,  # whole episodes are kept, so hold out pairs to fit the noise
            **common,
        )
    policy = result.policy
    return lambda obs, info, rng: policy.act(obs)


def evaluate(env_id: str, kwargs: dict, act, episodes: int) -> dict:
    env = gym.make(env_id, **kwargs)
    dt = env.unwrapped.world.dt
    out = {
        "episodes": episodes,
        "success": 0,
        "collision_episodes": 0,
        "ego_fault": 0,
        "supervised_fault": 0,
        "cut_in": 0,
        "red_light_runs": 0,
        "failed_to_yield": 0,
        "timeouts": 0,
        "time_to_goal_s": [],
    }
    for i in range(episodes):
        seed = EVAL_SEED + i
        rng = np.random.default_rng(seed)
        obs, info = env.reset(seed=seed)
        hit, steps = False, 0
        while True:
            obs, _, term, trunc, info = env.step(act(obs, info, rng))
            steps += 1
            for c in info["collisions"]:
                hit = True
                if c["cut_in"]:
                    out["cut_in"] += 1
                elif 0 in c["at_fault"]:
                    out["ego_fault"] += 1
                else:
                    out["supervised_fault"] += 1
            if term or trunc:
                break
        out["success"] += bool(info.get("is_success", False))
        out["collision_episodes"] += hit
        out["red_light_runs"] += bool(info["ego_ran_red_light"])
        out["timeouts"] += bool(trunc and not term)
        out["failed_to_yield"] += bool(info["ego_failed_to_yield"])
        if info["ego_arrived"]:
            out["time_to_goal_s"].append(steps * dt)
    times = out.pop("time_to_goal_s")
    out["success_rate"] = out["success"] / episodes
    out["mean_time_to_goal_s"] = round(float(np.mean(times)), 2) if times else None
    return out


def job(args: tuple) -> dict:
    env_id, method, episodes, demos, ppo_steps, seed, extra = args
    kwargs = {**ENVS[env_id], **json.loads(extra)}
    t0 = time.process_time()
    act = _train(method, env_id, kwargs, demos, ppo_steps, seed)
    row = {"env_id": env_id, "method": method, "demos": demos, "ppo_steps": ppo_steps}
    row["env_kwargs"] = extra
    if act is None:
        row["skipped"] = "stable-baselines3 not installed (pip install 'fluids-bench[train]')"
        return row
    train_s = time.process_time() - t0
    row.update(evaluate(env_id, kwargs, act, episodes))
    row["train_cpu_s"] = round(train_s, 1)
    row["cpu_s"] = round(time.process_time() - t0, 1)
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", nargs="+", default=list(ENVS), choices=list(ENVS))
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--demos", type=int, default=60, help="supervisor / learner rollouts")
    parser.add_argument("--ppo-steps", type=int, default=100_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument(
        "--env-kwargs",
        default="{}",
        help="JSON kwargs added to every env (a scene variant), e.g. '{\"num_cars\": 15}'",
    )
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    announce(
        "~15 min on 2 cores at --episodes 200 --demos 60 (PPO rows add ~5 min and need the train extra)"
    )
    extra = json.dumps(json.loads(args.env_kwargs), sort_keys=True)
    jobs = [
        (e, m, args.episodes, args.demos, args.ppo_steps, args.seed, extra)
        for e in args.envs
        for m in args.methods
    ]
    log = f"{args.out}.jsonl" if args.out else None
    done = {
        (
            r["env_id"],
            r["method"],
            r.get("episodes"),
            r["demos"],
            r["ppo_steps"],
            r.get("env_kwargs", "{}"),
        ): r
        for r in read_rows(log)
    }

    def key(j):
        return (j[0], j[1], j[2], j[3], j[4], j[6])

    # the slowest trainers first, so that the cheap jobs fill in around them
    todo = sorted((j for j in jobs if key(j) not in done), key=lambda j: j[1] not in SLOW)
    with ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool:
        futures = {pool.submit(job, j): j for j in todo}
        for fut in tqdm(as_completed(futures), total=len(futures), unit="job"):
            j, row = futures[fut], fut.result()
            row.setdefault("episodes", j[2])
            done[key(j)] = row
            if log:
                with open(log, "a") as f:
                    f.write(json.dumps(row) + "\n")
    rows = [done[key(j)] for j in jobs]
    if args.out:
        with open(f"{args.out}.tmp", "w") as f:
            json.dump(rows, f, indent=1)
        os.replace(f"{args.out}.tmp", args.out)
    print(
        "| env | method | episodes | success | collision episodes | ego at fault | "
        "supervised at fault | cut-ins | red-light runs | failed to yield | timeouts | "
        "mean time to goal (s) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if "skipped" in r:
            print(f"| {r['env_id']} | {r['method']} | – | skipped: {r['skipped']} |||||||||")
            continue
        print(
            f"| {r['env_id']} | {r['method']} | {r['episodes']} | {r['success_rate']:.2f} | "
            f"{r['collision_episodes']} | {r['ego_fault']} | {r['supervised_fault']} | "
            f"{r['cut_in']} | {r['red_light_runs']} | {r.get('failed_to_yield', '–')} | "
            f"{r.get('timeouts', '–')} | "
            f"{r['mean_time_to_goal_s']} |"
        )


if __name__ == "__main__":
    main()
