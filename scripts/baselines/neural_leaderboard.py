"""Neural baselines on the suite: BC, DAgger and DART with `MLPLearner` on every task, trained
with `fluids-bench train`, then evaluated with `fluids-bench evaluate` into scorecards.

The budget is the decision-tree baselines' (`scripts/baselines/leaderboard.py`'s `BUDGET` and
`BASELINES`, mirrored here: the same numbers, so a network and a tree get the same labels): per
task the same number of supervisor-labelled rollouts for every algorithm and the same cap on the
labels kept per rollout (`--samples-per-demo`); DAgger starts with one demonstration, counted in
the rollouts; DART refits its noise every 5 rollouts (on GridWorld, Singulation and grasping from 10 % of
each demonstration held out: their supervisor's episodes leave no pair beyond the cap); learning-curve points (5 episodes on train
seeds) at a quarter, half and all of the rollouts; seed 0. The MLP is `MLPLearner` with its
defaults (two hidden layers of 256, Adam 1e-3, up to 100 epochs per fit, early stopping after 10
epochs without a lower validation loss on 10 % of the pairs, warm-started across iterations) on
one torch thread; GridWorld's runs train longer (300 epochs, patience 30: its ~60 validation
pairs make early stopping premature, see `neural_baselines.py`).

Stages (each skips finished work, so the same command continues an interrupted run):

* `train`: `fluids-bench train ... --resume` per (algorithm, task) into `--train-out`, cheapest
  tasks first; a complete train result is not run again.
* `evaluate`: `fluids-bench evaluate` of each algorithm's runs (one policy per task: the train
  result, whose saved learner is loaded) on the full suite's test and OOD sets into `--eval-out`
  (the shared reference episodes), to `docs/results/scorecard_mlp_<algo>.json`; `--tasks`
  restricts it and `--episodes N` caps every set (a shortened scorecard, labelled so).

    nice -n 15 python scripts/baselines/neural_leaderboard.py train --algos bc dagger dart
    nice -n 15 python scripts/baselines/neural_leaderboard.py evaluate --algos bc --tasks gridworld
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

from fluids_bench.benchmark.suite import SUITE

ALGOS = ("bc", "dagger", "dart")
# cheapest tasks first (per-episode cost, label count and input size)
ORDER = (
    "gridworld",
    "fluids",
    "singulation",
    "grasping",
    "hopper",
    "walker2d",
    "halfcheetah",
    "humanoid",
    "track",
)
# task -> (rollouts, labels kept per rollout): scripts/baselines/leaderboard.py's BUDGET
BUDGET: dict[str, tuple[int, int]] = {
    "fluids": (30, 75),
    "gridworld": (20, 30),
    "singulation": (20, 50),
    "grasping": (20, 50),
    "track": (20, 50),
    "hopper": (20, 100),
    "walker2d": (20, 100),
    "halfcheetah": (20, 100),
    "humanoid": (20, 100),
}
EVAL_EPISODES = 5
# algorithm -> (options, initial demonstrations): leaderboard.py's BASELINES
OPTIONS: dict[str, tuple[dict[str, Any], int]] = {
    "bc": ({}, 0),
    "dagger": ({"--initial-demos": 1}, 1),
    "dart": ({"--update-every": 5}, 0),
}
# Where the supervisor's episodes are not longer than the cap (GridWorld's 30 steps; Singulation's
# and grasping's supervisor finishes in fewer than 50), DART has no pair beyond the cap to estimate
# its noise from (train refuses the run): there it holds out 10 % of each demonstration
DART_HELDOUT: dict[str, float] = {"gridworld": 0.1, "singulation": 0.1, "grasping": 0.1}
LEARNER = "fluids_bench.algos.learners:MLPLearner"
LEARNER_PARAMS: dict[str, dict[str, Any]] = {"gridworld": {"epochs": 300, "patience": 30}}
SEED = 0


def train_command(algo: str, task_name: str, out: Path) -> list[str]:
    """The `fluids-bench train` command of one run."""
    task = SUITE.task(task_name)
    rollouts, samples = BUDGET[task_name]
    options, initial = OPTIONS[algo]
    points = sorted({rollouts // 4, rollouts // 2})
    command = ["fluids-bench", "train", "--env", task.env_id, "--algo", algo]
    for key, value in task.env_kwargs.items():
        command += ["--env-kwarg", f"{key}={json.dumps(value)}"]
    command += ["--policy", LEARNER, "--policy-param", "threads=1"]
    for key, value in LEARNER_PARAMS.get(task_name, {}).items():
        command += ["--policy-param", f"{key}={value}"]
    command += [
        "--iterations", str(rollouts - initial),
        "--samples-per-demo", str(samples),
        "--eval-episodes", str(EVAL_EPISODES),
        "--eval-at", *[str(p - initial) for p in points if p > initial],
        "--seed", str(SEED),
        "--out", str(out),
        "--workers", "1",
        "--no-progress",
        "--resume",
    ]  # fmt: skip
    for option, value in options.items():
        command += [option, str(value)]
    if algo == "dart" and task_name in DART_HELDOUT:
        command += ["--heldout-fraction", str(DART_HELDOUT[task_name])]
    return command


def result_path(algo: str, task_name: str, out: Path) -> Path:
    return out / f"{algo}_{SUITE.task(task_name).env_id}_seed{SEED}.json"


def is_complete(path: Path) -> bool:
    return path.is_file() and bool(json.loads(path.read_text()).get("complete"))


def run(command: list[str], log: Path) -> int:
    print(" ".join(command), flush=True)
    with open(log, "a", encoding="utf-8") as handle:
        handle.write("$ " + " ".join(command) + "\n")
        handle.flush()
        return subprocess.call(command, stdout=handle, stderr=subprocess.STDOUT)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("stage", choices=("train", "evaluate"))
    parser.add_argument("--algos", nargs="+", choices=ALGOS, default=list(ALGOS))
    parser.add_argument("--tasks", nargs="+", choices=ORDER, default=list(ORDER))
    parser.add_argument("--train-out", type=Path, default=Path("runs/neural/train"))
    parser.add_argument("--eval-out", type=Path, default=Path("runs/evaluate"))
    parser.add_argument("--results", type=Path, default=Path("docs/results"))
    parser.add_argument(
        "--episodes", type=int, default=None,
        help="evaluate: the first N episodes of each set (a shortened scorecard)",
    )  # fmt: skip
    args = parser.parse_args()
    args.train_out.mkdir(parents=True, exist_ok=True)
    log = args.train_out / "neural_leaderboard.log"
    tasks = [t for t in ORDER if t in args.tasks]
    if args.stage == "train":
        for task in tasks:
            for algo in args.algos:
                if is_complete(result_path(algo, task, args.train_out)):
                    continue
                rc = run(train_command(algo, task, args.train_out), log)
                print(f"{algo} on {task}: exit {rc}", flush=True)
        return 0
    for algo in args.algos:
        done = [t for t in tasks if is_complete(result_path(algo, t, args.train_out))]
        if not done:
            print(f"{algo}: no complete train result among {tasks}", flush=True)
            continue
        command = ["fluids-bench", "evaluate"]
        for task in done:
            command += ["--policy", f"{task}={result_path(algo, task, args.train_out)}"]
        if args.episodes is not None:
            command += ["--episodes", str(args.episodes)]
        command += [
            "--name", f"mlp_{algo}", "--out", str(args.eval_out), "--workers", "1",
            "--scorecard", str(args.results / f"scorecard_mlp_{algo}.json"), "--no-progress",
        ]  # fmt: skip
        rc = run(command, log)
        print(f"evaluate mlp_{algo} on {done}: exit {rc}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
