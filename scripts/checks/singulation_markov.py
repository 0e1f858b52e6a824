"""Singulation's supervisor with its cached push plan against a Markov one (a supervisor built
afresh at every state), printed as JSON.

The shipped supervisor caches its push plan (which object, which direction, whether the push has
started) and replans only when the objects leave it, so its label depends on history: a
supervisor constructed anew from the same state replans and may label differently
(`supervisor_purity.py --copy fresh`). The Markov alternative is what DAgger's theory asks for:
pi*(s) = what a fresh supervisor does in s. This script drives seeded Singulation-v0 episodes
under each and reports success, episode length and CPU seconds per label (both on the same
seeds, interleaved).

    PYTHONPATH=. python scripts/checks/singulation_markov.py --episodes 10
"""

from __future__ import annotations

import argparse
import json
import time

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.tasks.singulation.supervisor import SingulationSupervisor

SEED = 600_000


def episode(env: gym.Env, seed: int, markov: bool) -> dict:
    env.reset(seed=seed)
    inner = env.unwrapped
    steps, cpu = 0, 0.0
    while True:
        start = time.process_time()
        if markov:  # a supervisor constructed anew from this state
            inner._supervisor = SingulationSupervisor()
        label = inner.supervisor_action()
        cpu += time.process_time() - start
        _, _, terminated, truncated, info = env.step(label)
        steps += 1
        if terminated or truncated:
            return {"success": bool(info.get("is_success", False)), "steps": steps, "cpu": cpu}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=10)
    args = parser.parse_args()
    env = gym.make("Singulation-v0")
    runs: dict[str, list[dict]] = {"cached_plan": [], "markov": []}
    for k in range(args.episodes):
        for name in runs:
            runs[name].append(episode(env, SEED + k, name == "markov"))
    out = {
        "env_id": "Singulation-v0",
        "seeds": [SEED, SEED + args.episodes - 1],
        "results": {
            name: {
                "success": float(np.mean([e["success"] for e in eps])),
                "mean_steps": float(np.mean([e["steps"] for e in eps])),
                "ms_per_label": 1e3
                * sum(e["cpu"] for e in eps)
                / max(1, sum(e["steps"] for e in eps)),
            }
            for name, eps in runs.items()
        },
    }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
