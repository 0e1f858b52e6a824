"""What PPO's discount makes of FLUIDS-v2's reward: trained policies' returns at γ = 0.99.

Runs each given stable-baselines3 model (deterministic) and the supervisor on the same seeded
``FLUIDS-v2`` episodes at the velocity level and reports, per policy, the success rate, the
mean episode length, and the mean return undiscounted and discounted at ``--gamma`` (PPO's
default 0.99), each under reward version 1 with its failure terms weighted 1 and ``--penalty``
(``failure_penalty``). The weighted rewards are computed from the same episodes:
a failure term is the step's reward difference between the two weights, so one rollout gives
both. Written to ``--out`` (JSON).

    python scripts/baselines/fluids_discount.py \\
        --models "rushing=runs/rl/.../ppo_s1/model.zip" "waiting=runs/rl/.../ppo_s0/model.zip" \\
        --episodes 100 --out docs/results/fluids_discount.json
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.results import write_json_atomic

ENV_ID = "FLUIDS-v2"
KWARGS = {"action_level": "velocity", "render_mode": None}
EVAL_SEED = 100_000  # the RL baselines' evaluation seeds


def rollouts(act, episodes: int, gamma: float, penalty: float) -> dict:
    """One env per weight, stepped with the same actions (the weight changes no dynamics)."""
    envs = [gym.make(ENV_ID, failure_penalty=w, **KWARGS) for w in (1.0, penalty)]
    out = {"success": 0, "lengths": [], "returns": [[], []], "discounted": [[], []]}
    for i in range(episodes):
        obs = [env.reset(seed=EVAL_SEED + i)[0] for env in envs]
        ret, disc, steps, scale = [0.0, 0.0], [0.0, 0.0], 0, 1.0
        while True:
            action = act(obs[0], envs[0])
            results = [env.step(action) for env in envs]
            for k, (o, r, *_rest) in enumerate(results):
                obs[k] = o
                ret[k] += r
                disc[k] += scale * r
            scale *= gamma
            steps += 1
            _, _, term, trunc, info = results[0]
            if term or trunc:
                break
        out["success"] += bool(info.get("is_success", False))
        out["lengths"].append(steps)
        for k in (0, 1):
            out["returns"][k].append(ret[k])
            out["discounted"][k].append(disc[k])
    return {
        "episodes": episodes,
        "success_rate": out["success"] / episodes,
        "mean_length": round(float(np.mean(out["lengths"])), 1),
        "return": [round(float(np.mean(r)), 3) for r in out["returns"]],
        "discounted_return": [round(float(np.mean(r)), 3) for r in out["discounted"]],
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--models", nargs="+", required=True, help="NAME=PATH of stable-baselines3 PPO models"
    )
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--gamma", type=float, default=0.99)
    parser.add_argument("--penalty", type=float, default=3.0, help="the other failure weight")
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    from stable_baselines3 import PPO

    policies = {"supervisor": lambda obs, env: env.unwrapped.supervisor_action()}
    for spec in args.models:
        name, sep, path = spec.partition("=")
        if not sep:
            parser.error(f"--models takes NAME=PATH, got {spec!r}")
        model = PPO.load(path, device="cpu")
        policies[name] = lambda obs, env, m=model: m.predict(obs, deterministic=True)[0]
    rows = {}
    for name, act in tqdm(policies.items(), desc="policies"):
        rows[name] = rollouts(act, args.episodes, args.gamma, args.penalty)
    result = {
        "command": "python " + shlex.join(["scripts/baselines/fluids_discount.py", *sys.argv[1:]]),
        "env_id": ENV_ID,
        "env_kwargs": {"action_level": "velocity"},
        "gamma": args.gamma,
        "penalties": [1.0, args.penalty],
        "eval_seeds": f"{EVAL_SEED} .. {EVAL_SEED + args.episodes - 1}",
        "policies": rows,
    }
    write_json_atomic(args.out, result)
    print(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
