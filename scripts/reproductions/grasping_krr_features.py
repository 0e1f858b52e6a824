"""Ablation for Fig. 6.4: Behavior Cloning with RBF kernel ridge regression on GraspingInClutter-v0,
on standardised features (the suite's ``kernel_ridge`` family, which the SHIV experiment uses)
vs raw features (scikit-learn's ``KernelRidge(kernel="rbf")`` as it comes, gamma = 1/22).

For each layout (``layout_seed`` = 0 .. ``--layouts`` - 1, as the experiment's rounds), the
learner is fitted on the first n supervisor demonstrations (seeds 100, 101, ...; n in
``--demos``) and evaluated on ``--eval-episodes`` episodes (seeds 300, 301, ...), with ``alpha``
in ``--alphas``. Reports the mean cost (knocked off + 10 x not grasped) per setting over the
layouts, as JSON and a Markdown table.

Resumable: every finished (layout, alpha, features, n) cell is appended to
``<out>/krr_features.jsonl``; a rerun skips those. Usage:
``python scripts/reproductions/grasping_krr_features.py --workers 2``. Needs the package importable.
"""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import gymnasium as gym
import numpy as np
from sklearn.kernel_ridge import KernelRidge
from tqdm import tqdm

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.policies import PolicySpec, fit_policy
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.jsonl import read_rows
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import announce

ENV_ID = "GraspingInClutter-v0"
FEATURES = ("standardised", "raw")


def demonstrations(env: gym.Env, n: int) -> tuple[np.ndarray, np.ndarray]:
    """States and labels of ``n`` supervisor episodes (seeds 100, 101, ...)."""
    states, labels = [], []
    for d in range(n):
        obs, info = env.reset(seed=100 + d)
        done = False
        while not done:
            states.append(obs)
            labels.append(info["supervisor_action"])
            obs, _, terminated, truncated, info = env.step(info["supervisor_action"])
            done = terminated or truncated
    return np.array(states), np.array(labels)


def cell(job: tuple[int, float, str, int, int]) -> dict:
    """Mean cost of BC on ``n`` demonstrations of one layout, one alpha, one feature scaling."""
    layout, alpha, features, n, episodes = job
    env = gym.make(ENV_ID, layout_seed=layout)
    X, Y = demonstrations(env, n)
    if features == "standardised":
        policy = fit_policy(
            PolicySpec("kernel_ridge", {"alpha": alpha, "gamma": None}), env.action_space, X, Y, 0
        )

        def act(obs: np.ndarray) -> np.ndarray:
            return policy.act(obs)
    else:
        model = KernelRidge(alpha=alpha, kernel="rbf").fit(X, Y)

        def act(obs: np.ndarray) -> np.ndarray:
            action = model.predict(obs[None].astype(np.float64))[0]
            return np.clip(action, env.action_space.low, env.action_space.high).astype(np.float32)

    costs = []
    for k in range(episodes):
        obs, info = env.reset(seed=300 + k)
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(act(obs))
            done = terminated or truncated
        costs.append(float(info["cost"]))
    return {
        "layout": layout,
        "alpha": alpha,
        "features": features,
        "demos": n,
        "episodes": episodes,
        "mean_cost": float(np.mean(costs)),
        "success": float(np.mean([c == 0 for c in costs])),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--layouts", type=int, default=8)
    parser.add_argument("--demos", type=int, nargs="+", default=[1, 2, 4, 8])
    parser.add_argument("--alphas", type=float, nargs="+", default=[1.0, 1e-3])
    parser.add_argument("--eval-episodes", type=int, default=10)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("out/grasping_krr_features"))
    args = parser.parse_args()
    announce(
        "tens of minutes on 2 cores (one fit per layout, alpha, feature set and demonstration count); finished cells are reused"
    )
    if min(args.layouts, args.eval_episodes, args.workers, *args.demos) < 1:
        parser.error("--layouts, --demos, --eval-episodes, --workers: >= 1")
    args.out.mkdir(parents=True, exist_ok=True)
    log = args.out / "krr_features.jsonl"
    key = ("layout", "alpha", "features", "demos", "episodes")
    done = {tuple(row[k] for k in key): row for row in read_rows(log)}
    jobs = [
        (layout, alpha, features, n, args.eval_episodes)
        for alpha in args.alphas
        for features in FEATURES
        for n in args.demos
        for layout in range(args.layouts)
    ]
    todo = [job for job in jobs if job not in done]
    with (
        ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool,
        open(log, "a") as f,
    ):
        futures = [pool.submit(cell, job) for job in todo]
        for future in tqdm(as_completed(futures), total=len(futures), unit="cell"):
            row = future.result()
            done[tuple(row[k] for k in key)] = row
            f.write(json.dumps(row) + "\n")
            f.flush()
    table = {}
    for alpha in args.alphas:
        for features in FEATURES:
            for n in args.demos:
                rows = [
                    done[(layout, alpha, features, n, args.eval_episodes)]
                    for layout in range(args.layouts)
                ]
                costs = np.array([r["mean_cost"] for r in rows])
                table[f"alpha={alpha:g} {features} demos={n}"] = {
                    "mean_cost": round(float(costs.mean()), 3),
                    "cost_stderr": round(float(costs.std(ddof=1) / np.sqrt(len(costs))), 3)
                    if len(costs) > 1
                    else None,
                    "success": round(float(np.mean([r["success"] for r in rows])), 3),
                }
    report = {"env": ENV_ID, "settings": vars(args) | {"out": str(args.out)}, "results": table}
    write_json_atomic(args.out / "krr_features.json", report)
    print(json.dumps(report, indent=2))
    print("\n| alpha | features | " + " | ".join(f"{n} demo(s)" for n in args.demos) + " |")
    print("|---|---|" + "---|" * len(args.demos))
    for alpha in args.alphas:
        for features in FEATURES:
            cells = [table[f"alpha={alpha:g} {features} demos={n}"] for n in args.demos]
            print(
                f"| {alpha:g} | {features} | "
                + " | ".join(f"{c['mean_cost']:.2f} ± {c['cost_stderr']:.2f}" for c in cells)
                + " |"
            )


if __name__ == "__main__":
    main()
