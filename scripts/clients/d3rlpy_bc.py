"""d3rlpy as a client: a ``fluids-bench collect`` dataset loads with
``d3rlpy.datasets.get_minari`` and d3rlpy's behaviour cloning beats random actions on held-out
seeds. Writes ``docs/results/client_d3rlpy.json`` (read by docs/ecosystem.md).

d3rlpy 2.8.1 pins ``gymnasium==1.0.0``, so this runs in its own environment (the suite's lowest
supported Gymnasium); see docs/ecosystem.md for the venv's set-up. Run from the repository::

    MINARI_DATASETS_PATH=runs/d3rlpy-minari PYTHONPATH=. .venv-d3rlpy/bin/python \
        scripts/clients/d3rlpy_bc.py

It collects the dataset first (``--episodes`` supervisor episodes, seeds 0 ... N-1) unless it
exists, trains BC for ``--steps`` gradient steps on CPU (seed 0), and compares the mean return
of BC, random actions and the supervisor on ``--eval-episodes`` seeds from 100000 on.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from fluids_bench.algos.results import write_json_atomic  # noqa: E402
from fluids_bench.core.provenance import command_line, machine  # noqa: E402

EVAL_SEED = 100_000


def _returns(env, act, seeds) -> list[float]:
    out = []
    for seed in seeds:
        obs, info = env.reset(seed=seed)
        env.action_space.seed(seed)
        total, done = 0.0, False
        while not done:
            obs, reward, terminated, truncated, info = env.step(act(obs, info))
            total += float(reward)
            done = terminated or truncated
        out.append(total)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", default="Hopper-IL-v0")
    parser.add_argument("--dataset", default="clients/hopper-d3rlpy-v0")
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--eval-episodes", type=int, default=3)
    parser.add_argument("--out", default=str(ROOT / "docs/results/client_d3rlpy.json"))
    args = parser.parse_args()

    import d3rlpy
    import gymnasium
    import minari

    import fluids_bench  # noqa: F401  (registers the ids)

    if args.dataset not in minari.list_local_datasets():
        collect = [sys.executable, "-m", "fluids_bench.cli", "collect", "--env", args.env]
        collect += ["--episodes", str(args.episodes), "--dataset", args.dataset, "--no-progress"]
        subprocess.run(collect, check=True)
    dataset, env = d3rlpy.datasets.get_minari(args.dataset)
    d3rlpy.seed(0)
    discrete = isinstance(env.action_space, gymnasium.spaces.Discrete)
    config = d3rlpy.algos.DiscreteBCConfig() if discrete else d3rlpy.algos.BCConfig()
    bc = config.create(device="cpu:0")
    bc.fit(
        dataset,
        n_steps=args.steps,
        n_steps_per_epoch=args.steps,
        show_progress=False,
        logger_adapter=d3rlpy.logging.NoopAdapterFactory(),
    )
    seeds = list(range(EVAL_SEED, EVAL_SEED + args.eval_episodes))
    rows = {
        "bc": _returns(env, lambda o, i: bc.predict(o[None].astype(np.float32))[0], seeds),
        "random": _returns(env, lambda o, i: env.action_space.sample(), seeds),
        "supervisor": _returns(env, lambda o, i: i["supervisor_action"], seeds),
    }
    result = {
        "env": args.env,
        "dataset": args.dataset,
        "transitions": int(dataset.transition_count),
        "episodes": int(len(dataset.episodes)),
        "bc_steps": args.steps,
        "eval_seeds": [seeds[0], seeds[-1]],
        "mean_return": {k: float(np.mean(v)) for k, v in rows.items()},
        "returns": rows,
        "bc_beats_random": bool(np.mean(rows["bc"]) > np.mean(rows["random"])),
        "versions": {
            "d3rlpy": d3rlpy.__version__,
            "gymnasium": gymnasium.__version__,
            "minari": minari.__version__,
        },
        "command": command_line(),
        "machine": machine(),
    }
    write_json_atomic(args.out, result)
    print(json.dumps(result["mean_return"]))
    if not result["bc_beats_random"]:
        sys.exit("d3rlpy BC did not beat random actions")


if __name__ == "__main__":
    main()
