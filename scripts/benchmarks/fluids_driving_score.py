"""Driving scores of random, supervisor, BC and DAgger policies on a FLUIDS id, with intervals.

Reads `info["driving_score"]`, `info["route_completion"]`, `info["infractions"]` and
`info["is_success"]` at every episode's end (the ids that report the driving score: FLUIDS-v4).
BC and DAgger fit a regression tree (scikit-learn's `DecisionTreeRegressor`, or a classifier at
the behaviour level) on supervisor-labelled observations from training seeds; DAgger rolls its
learner out (beta = 0), labels every visited state and refits on the aggregate. Every policy is
evaluated on the same test seeds (disjoint from training seeds); intervals are 95 % percentile
bootstrap intervals of the mean over episodes (10,000 resamples, seeded).

    PYTHONPATH=. python scripts/benchmarks/fluids_driving_score.py --test-episodes 20 \\
        --train-episodes 10 --dagger-iterations 2 --results docs/results/fluids_v4_scores.json

`--env-kwargs '{"action_level": "control"}'` measures another action level on the same id.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import add_results_option, emit  # noqa: E402

TRAIN_SEED = 300_000  # training episodes: TRAIN_SEED + i (DAgger's iterations continue them)
TEST_SEED = 400_000  # test episodes: TEST_SEED + i, never used for training
POLICIES = ("random", "supervisor", "bc", "dagger")


def _flat(obs: Any) -> np.ndarray:
    return np.asarray(obs, dtype=np.float64).reshape(-1)


def rollout(env: gym.Env, seed: int, act, record: list | None = None) -> dict[str, Any]:
    """One episode under `act(obs, info) -> action`; with `record`, append (obs, label) pairs.
    Returns the episode's last info's score entries and its length."""
    obs, info = env.reset(seed=seed)
    steps = 0
    while True:
        if record is not None:
            record.append((_flat(obs), np.asarray(info["supervisor_action"])))
        obs, _, terminated, truncated, info = env.step(act(obs, info))
        steps += 1
        if terminated or truncated:
            return {
                "seed": seed,
                "steps": steps,
                "driving_score": float(info["driving_score"]),
                "route_completion": float(info["route_completion"]),
                "infractions": dict(info["infractions"]),
                "is_success": bool(info.get("is_success", False)),
            }


class TreePolicy:
    """A scikit-learn tree fitted on (observation, label) pairs."""

    def __init__(self, space: gym.Space, seed: int) -> None:
        from sklearn.tree import DecisionTreeClassifier, DecisionTreeRegressor

        self.discrete = isinstance(space, gym.spaces.Discrete)
        tree = DecisionTreeClassifier if self.discrete else DecisionTreeRegressor
        self.model = tree(min_samples_leaf=5, random_state=seed)
        self.space = space

    def fit(self, pairs: list) -> TreePolicy:
        X = np.stack([p[0] for p in pairs])
        y = np.stack([p[1].reshape(-1) for p in pairs])
        self.model.fit(X, y.ravel() if self.discrete else y)
        return self

    def __call__(self, obs, info):
        # the fitted tree's own predict: one row without scikit-learn's per-call checks
        value = self.model.tree_.predict(_flat(obs)[None].astype(np.float32))[0]
        if self.discrete:
            return int(self.model.classes_[value[0].argmax()])
        return value[:, 0].astype(self.space.dtype).reshape(self.space.shape)


def interval(values: list[float], seed: int = 0) -> dict[str, float]:
    """Mean and 95 % percentile bootstrap interval of the mean."""
    x = np.asarray(values, dtype=np.float64)
    rng = np.random.default_rng(seed)
    means = x[rng.integers(0, len(x), (10_000, len(x)))].mean(axis=1)
    low, high = np.percentile(means, [2.5, 97.5])
    return {"mean": float(x.mean()), "low": float(low), "high": float(high)}


def summary(episodes: list[dict]) -> dict[str, Any]:
    counts: dict[str, int] = {}
    for e in episodes:
        for k, v in e["infractions"].items():
            counts[k] = counts.get(k, 0) + int(v)
    return {
        "episodes": len(episodes),
        "driving_score": interval([e["driving_score"] for e in episodes]),
        "route_completion": interval([e["route_completion"] for e in episodes]),
        "success": interval([float(e["is_success"]) for e in episodes]),
        "infractions": counts,
        "mean_steps": float(np.mean([e["steps"] for e in episodes])),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env-id", default="FLUIDS-v4")
    parser.add_argument("--env-kwargs", default="{}", help="JSON kwargs for gym.make")
    parser.add_argument("--test-episodes", type=int, default=20)
    parser.add_argument("--train-episodes", type=int, default=10, help="BC's demonstrations")
    parser.add_argument("--dagger-iterations", type=int, default=2)
    parser.add_argument(
        "--dagger-episodes", type=int, default=5, help="learner episodes per iteration"
    )
    parser.add_argument("--policies", nargs="+", choices=POLICIES, default=list(POLICIES))
    add_results_option(parser)
    args = parser.parse_args()
    kwargs = json.loads(args.env_kwargs)
    env = gym.make(args.env_id, **kwargs)
    env.action_space.seed(0)
    test = [TEST_SEED + i for i in range(args.test_episodes)]
    out: dict[str, Any] = {
        "env_id": args.env_id,
        "env_kwargs": kwargs,
        "test_seeds": [test[0], test[-1]] if test else [],
        "train_seeds_from": TRAIN_SEED,
        "policies": {},
    }
    demos: list = []
    seconds: dict[str, float] = {}

    def evaluate(name: str, act) -> None:
        start = time.perf_counter()
        episodes = [rollout(env, s, act) for s in test]
        seconds[name] = time.perf_counter() - start
        out["policies"][name] = {**summary(episodes), "per_episode": episodes}
        print(f"{name}: {out['policies'][name]['driving_score']}", file=sys.stderr)

    if "random" in args.policies:
        evaluate("random", lambda obs, info: env.action_space.sample())
    supervise = lambda obs, info: info["supervisor_action"]  # noqa: E731
    if "supervisor" in args.policies:
        evaluate("supervisor", supervise)
    if {"bc", "dagger"} & set(args.policies):
        for i in range(args.train_episodes):
            rollout(env, TRAIN_SEED + i, supervise, demos)
        bc = TreePolicy(env.action_space, 0).fit(demos)
        out["bc_labels"] = len(demos)
        if "bc" in args.policies:
            evaluate("bc", bc)
    if "dagger" in args.policies:
        learner, data, seed = bc, list(demos), TRAIN_SEED + args.train_episodes
        for _ in range(args.dagger_iterations):
            for _ in range(args.dagger_episodes):
                rollout(env, seed, learner, data)  # the learner drives, the supervisor labels
                seed += 1
            learner = TreePolicy(env.action_space, 0).fit(data)
        out["dagger_labels"] = len(data)
        evaluate("dagger", learner)
    sup = out["policies"].get("supervisor", {}).get("driving_score", {}).get("mean")
    rnd = out["policies"].get("random", {}).get("driving_score", {}).get("mean")
    if sup and rnd is not None:
        out["random_over_supervisor"] = rnd / sup
    out["evaluation_seconds"] = seconds
    emit(out, args)


if __name__ == "__main__":
    main()
