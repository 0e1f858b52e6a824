"""DAgger with retroactive labels from a simulated person, end to end (ch. 5's protocol).

1. a simulated person (the supervisor delayed and noisy) teleoperates a few episodes
   (``fluids-bench teleop --simulated-human``), and BC is fit on them (iteration 0);
2. each iteration: the learner's rollouts are collected as a dataset, relabelled offline by the
   simulated person (the relabelling tool, states rebuilt from the dataset), aggregated, and the
   learner refit (:func:`fluids_bench.human.offline.retroactive_dagger`).

A person can take the simulated one's place at step 1 (``fluids-bench teleop``) and in every
relabelling (``fluids-bench relabel``); the datasets are kept under ``--namespace``.

    python scripts/training/human_dagger.py --env GridWorld-v0 --iterations 4 \
        --results docs/results/human_dagger.json
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time
from dataclasses import asdict


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="GridWorld-v0")
    parser.add_argument("--teleop-episodes", type=int, default=2)
    parser.add_argument("--iterations", type=int, default=4)
    parser.add_argument("--rollouts", type=int, default=2, help="learner rollouts per iteration")
    parser.add_argument("--eval-episodes", type=int, default=20)
    parser.add_argument("--max-steps", type=int, default=None)
    parser.add_argument(
        "--human",
        default="delay=2,noise_std=0.1,epsilon=0.05",
        help="the simulated person while teleoperating",
    )
    parser.add_argument(
        "--labeller",
        default="delay=0,noise_std=0.1,epsilon=0.05",
        help="the simulated person while relabelling",
    )
    parser.add_argument("--policy", default="tree")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--namespace", default="human-dagger")
    parser.add_argument(
        "--datasets",
        default=None,
        help="MINARI_DATASETS_PATH for the run (default: a temporary folder)",
    )
    parser.add_argument("--results", default=None, help="write the records as JSON here")
    args = parser.parse_args(argv)
    print("expected run time: ~30 s on 2 cores (GridWorld-v0, the defaults)")
    if args.datasets is None:
        os.environ["MINARI_DATASETS_PATH"] = tempfile.mkdtemp(prefix="human-dagger-")
    else:
        os.environ["MINARI_DATASETS_PATH"] = args.datasets

    from fluids_bench.algos.policies import PolicySpec
    from fluids_bench.cli import main as cli
    from fluids_bench.human.offline import retroactive_dagger
    from fluids_bench.human.simulated import SimulatedHuman

    started = time.perf_counter()
    teleop_id = f"{args.namespace}/teleop-v0"
    teleop = [
        "teleop",
        "--env",
        args.env,
        "--dataset",
        teleop_id,
        "--overwrite",
        "--episodes",
        str(args.teleop_episodes),
        "--seed",
        str(args.seed),
        "--simulated-human",
        args.human,
    ]
    if args.max_steps is not None:
        teleop += ["--max-steps", str(args.max_steps)]
    if cli(teleop) != 0:
        return 1
    records = retroactive_dagger(
        args.env,
        teleop_id,
        namespace=args.namespace,
        iterations=args.iterations,
        rollouts=args.rollouts,
        labeller=SimulatedHuman.parse(args.labeller),
        policy=PolicySpec(args.policy),
        eval_episodes=args.eval_episodes,
        seed=args.seed,
        max_steps=args.max_steps,
    )
    for r in records:
        print(
            f"iteration {r.iteration}: {r.pairs} pairs, {r.labels_changed:.0%} of the learner's "
            f"actions relabelled differently, return {r.mean_return:.2f}, "
            f"success {r.success_rate:.2f}"
        )
    import gymnasium as gym

    from fluids_bench.human.offline import supervisor_return

    reference = supervisor_return(
        gym.make(args.env), args.eval_episodes, 10_000 + args.seed, args.max_steps
    )
    print(f"supervisor: return {reference:.2f}")
    if args.results:
        from fluids_bench.algos.results import write_json_atomic

        write_json_atomic(
            args.results,
            {
                "command": "python " + " ".join([sys.argv[0], *(argv or sys.argv[1:])]),
                "env_id": args.env,
                "settings": {
                    k: v for k, v in vars(args).items() if k not in ("results", "datasets")
                },
                "seeds": {"teleop": args.seed, "evaluation": 10_000 + args.seed},
                "machine": f"{platform.machine()}, {os.cpu_count()} cores",
                "seconds": round(time.perf_counter() - started, 1),
                "supervisor_mean_return": reference,
                "iterations": [asdict(r) for r in records],
            },
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
