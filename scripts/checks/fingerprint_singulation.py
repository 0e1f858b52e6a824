"""Fingerprints of seeded Singulation-v0 episodes and plans, printed as JSON.

A speed change to the simulator or the supervisor must not change what either does. This hashes
(SHA-256) everything the env returns over seeded episodes in several regimes, and the behaviour
level's pick on seeded states:

* ``supervisor``: the supervisor acts, a seeded perturbation every 7th step (episodes leave the
  nominal path, so labels are asked off it);
* ``noise_0.5``: the label plus N(0, 0.5²) noise every step (many replans from odd states);
* ``random``: uniform random actions, the label computed every step (the fingertip anywhere);
* ``pixels``: as ``supervisor`` with ``obs_type=["state", "pixels"]``;
* ``plans``: ``plan_push`` on the states of the ``random`` episodes every 5th step (target, push
  line, end, predicted progress and steps, bit for bit).

Uses the env's public API plus ``plan_push``, so the same script runs on an older checkout:

    PYTHONPATH=/path/to/old python scripts/checks/fingerprint_singulation.py > old.json
    PYTHONPATH=. python scripts/checks/fingerprint_singulation.py > new.json
    diff old.json new.json
"""

from __future__ import annotations

import argparse
import hashlib
import json

import gymnasium as gym
import numpy as np
from fingerprint_episodes import _feed  # the same canonical hashing (scripts/ is on the path)

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core.provenance import announce
from fluids_bench.tasks.singulation.supervisor import plan_push

ENV_ID = "Singulation-v0"


def _action(mode: str, space: gym.spaces.Box, label: np.ndarray, rng, k: int) -> np.ndarray:
    if mode == "random":
        return rng.uniform(-1.0, 1.0, 2).astype(np.float32)
    if mode == "noise_0.5":
        return np.clip(label + rng.normal(0.0, 0.5, 2), -1.0, 1.0).astype(np.float32)
    if k % 7 == 3:
        return np.clip(label + rng.normal(0.0, 0.3, 2), -1.0, 1.0).astype(np.float32)
    return label


def episodes_hash(mode: str, seeds: range, steps: int, plans: hashlib._Hash | None = None) -> str:
    kwargs = {"obs_type": ["state", "pixels"]} if mode == "pixels" else {}
    env = gym.make(ENV_ID, **kwargs)
    h = hashlib.sha256()
    for seed in seeds:
        rng = np.random.default_rng(seed)
        obs, info = env.reset(seed=seed)
        _feed(h, [obs, info])
        for k in range(steps):
            out = env.step(_action(mode, env.action_space, info["supervisor_action"], rng, k))
            _feed(h, list(out))
            info = out[4]
            if plans is not None and k % 5 == 0:
                world = env.unwrapped.world
                plan = plan_push(world, world.poses())
                _feed(
                    plans,
                    None
                    if plan is None
                    else [
                        plan.target,
                        plan.origin,
                        plan.direction,
                        plan.end,
                        plan.predicted_progress,
                        plan.predicted_steps,
                    ],
                )
            if out[2] or out[3]:
                break
    env.close()
    return h.hexdigest()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=40, help="episodes per regime")
    parser.add_argument("--steps", type=int, default=150, help="step limit per episode")
    args = parser.parse_args()
    announce("~1 min on one core")
    seeds = range(args.seeds)
    plans = hashlib.sha256()
    out = {
        "supervisor": episodes_hash("supervisor", seeds, args.steps),
        "noise_0.5": episodes_hash("noise_0.5", seeds, args.steps),
        "random": episodes_hash("random", range(args.seeds // 2), args.steps, plans),
        "pixels": episodes_hash("pixels", range(args.seeds // 4), args.steps),
    }
    out["plans"] = plans.hexdigest()
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
