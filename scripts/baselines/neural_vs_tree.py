"""Why an MLP and a decision tree differ on the same BC data: both fitted on the labels of one
BC run of `neural_leaderboard.py` (its demonstrations are the supervisor's, the same whatever
the learner), then scored on held-out supervisor episodes (other seeds).

Per task: training labels, the MLP's last fit (epochs run, best epoch, training and validation
loss), and each learner's error on its training labels and on the held-out episodes' (mean
squared error per action dimension for Box actions, the share of wrong actions for Discrete
ones). A learner that fits its labels but errs on new states of the supervisor's own
distribution generalises badly; one that errs little there but fails in closed loop compounds
its errors. Writes `--out` (JSON, atomically).

    nice -n 15 python scripts/baselines/neural_vs_tree.py --tasks gridworld fluids \\
        --out docs/results/neural_vs_tree.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.benchmark.suite import SUITE
from fluids_bench.core.provenance import command_line, machine

HELDOUT_SEED = 10_000_000  # train-range seeds far from the harness' draws


def _error(learner: Any, X: np.ndarray, y: np.ndarray, discrete: bool) -> float:
    predicted = np.asarray(learner.predict(X))
    if discrete:
        return float(np.mean(predicted.reshape(-1) != y.reshape(-1)))
    diff = predicted.reshape(len(y), -1) - y.reshape(len(y), -1)
    return float(np.mean(np.square(diff)))


def _bc_config(path: Path, learner: Any) -> Any:
    from fluids_bench.algos import bc

    settings = dict(json.loads(path.read_text())["config"])
    settings["policy"] = learner
    for key, value in settings.items():
        if isinstance(value, list):
            settings[key] = tuple(value)
    return bc.BCConfig(**settings)


def compare(task_name: str, train_out: Path, heldout: int) -> dict[str, Any]:
    from gymnasium import spaces

    from fluids_bench.algos import bc
    from fluids_bench.algos.learners import MLPLearner, SklearnLearner
    from fluids_bench.algos.learners.sklearn import PolicySpec
    from fluids_bench.data.collect import collect

    task = SUITE.task(task_name)
    path = train_out / f"bc_{task.env_id}_seed0.json"
    spec = json.loads(path.read_text())["config"]["policy"]["learner"]  # "module:factory {json}"
    _, _, text = spec.partition(" ")
    params = {"threads": 1, **(json.loads(text) if text else {})}
    mlp = MLPLearner(**params)
    result = bc.run(_bc_config(path, mlp))
    X, y = result.dataset.arrays()[:2]
    import gymnasium as gym

    env = gym.make(task.env_id, **task.env_kwargs)
    discrete = isinstance(env.action_space, spaces.Discrete)
    tree = SklearnLearner(PolicySpec("tree"))
    tree.set_spaces(env.observation_space, env.action_space)
    tree.fit(X, y)
    episodes = collect(
        task.env_id, heldout, env_kwargs=dict(task.env_kwargs), seed=HELDOUT_SEED, progress=False
    )
    Xh = np.concatenate([np.asarray(e.observations)[: len(e.actions)] for e in episodes])
    yh = np.concatenate([np.asarray(e.actions) for e in episodes])
    last = mlp.history[-1]
    return {
        "task": task_name,
        "env_id": task.env_id,
        "train_result": os.path.relpath(path),
        "training_labels": int(len(y)),
        "heldout_episodes": heldout,
        "heldout_labels": int(len(yh)),
        "error": "share of wrong actions" if discrete else "mean squared error per dimension",
        "mlp": {
            "params": params,
            "fits": mlp.fits,
            "last_fit": last,
            "train_error": _error(mlp, X, y, discrete),
            "heldout_error": _error(mlp, Xh, yh, discrete),
        },
        "tree": {
            "params": "SklearnLearner(PolicySpec('tree')): the tree baselines' learner",
            "train_error": _error(tree, X, y, discrete),
            "heldout_error": _error(tree, Xh, yh, discrete),
        },
        "bc_mlp_normalised_performance": result.final.normalised_performance,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", default=["gridworld", "fluids"])
    parser.add_argument("--train-out", type=Path, default=Path("runs/neural/train"))
    parser.add_argument("--heldout", type=int, default=10, help="held-out supervisor episodes")
    parser.add_argument("--out", type=Path, default=Path("docs/results/neural_vs_tree.json"))
    args = parser.parse_args(argv)
    rows = []
    for task in args.tasks:
        row = compare(task, args.train_out, args.heldout)
        print(json.dumps({k: row[k] for k in ("task", "training_labels", "mlp", "tree")}))
        rows.append(row)
    write_json_atomic(args.out, {"command": command_line(), "machine": machine(), "rows": rows})
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
