"""Times the shared-policy PPO recipe of the multi-agent page (SuperSuit + stable-baselines3).

Runs the recipe as the page shows it (``FLUIDS-MultiAgent-v2`` at the velocity level, three
controlled cars, black death, ``--copies`` worlds through
:func:`fluids_bench.core.pettingzoo_sb3.shared_policy_vec_env`, ``VecMonitor``, PPO with
stable-baselines3's defaults) for ``--steps`` steps, and writes its CPU and wall time, the steps
PPO actually took (whole rollouts of 2,048 steps per sub-env), the episodes finished and their
mean return, and how many "render_mode" warnings stable-baselines3 raised, to ``--out``.

    python scripts/baselines/multi_agent_recipe.py --out docs/results/rl_multi_agent_recipe.json
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import time
import warnings

import numpy as np

from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.pettingzoo_sb3 import shared_policy_vec_env
from fluids_bench.registration import make_parallel_env

RENDER_MODE_WARNING = "render_mode` attribute is not defined"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100_000, help="PPO total_timesteps")
    parser.add_argument("--copies", type=int, default=4, help="worlds (each with 3 cars)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", required=True, help="results JSON")
    args = parser.parse_args(argv)
    if args.steps < 1:
        raise ValueError(f"--steps must be >= 1, got {args.steps}")
    command = "python " + " ".join(shlex.quote(a) for a in sys.argv)
    print(f"expected run time: ~{args.steps / 700 / 60:.0f} min on one core")

    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor

    torch.set_num_threads(1)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # the recipe, as on the page
        env = make_parallel_env("FLUIDS-MultiAgent-v2", controlled_cars=3,
                                action_level="velocity", black_death=True, max_cycles=400)  # fmt: skip
        vec = VecMonitor(shared_policy_vec_env(env, copies=args.copies))
        model = PPO("MlpPolicy", vec, seed=args.seed, verbose=0).learn(args.steps)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    episodes = [e["r"] for e in model.ep_info_buffer]  # the last 100 finished (SB3's buffer)
    result = {
        "command": command,
        "env_id": "FLUIDS-MultiAgent-v2",
        "seeds": [args.seed],
        "settings": {
            "total_timesteps": args.steps,
            "copies": args.copies,
            "controlled_cars": 3,
            "sub_envs": int(vec.num_envs),
            "hyperparameters": "stable-baselines3 PPO defaults (MlpPolicy)",
            "machine": "2-core CI-class machine, shared, torch CPU build on one thread, "
            f"load average {os.getloadavg()[0]:.1f} at the end",
        },
        "steps_taken": int(model.num_timesteps),
        "cpu_s": round(cpu, 1),
        "wall_s": round(wall, 1),
        "last_episodes": len(episodes),
        "last_episodes_mean_return": round(float(np.mean(episodes)), 3) if episodes else None,
        "render_mode_warnings": sum(RENDER_MODE_WARNING in str(w.message) for w in caught),
    }
    write_json_atomic(args.out, result)
    print(result)


if __name__ == "__main__":
    main()
