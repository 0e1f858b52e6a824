"""Neural baselines: BC, DAgger and DART with the torch MLP next to a decision tree, and DAgger
with the CNN on FLUIDS' bird's-eye images, on small CPU budgets.

Setups (``--setups``, default all):

* ``gridworld``: GridWorld-v0 (``world_seed=3``), Discrete actions, 2-D state; BC, DAgger, DART
  with ``mlp`` and ``tree`` (``max_depth=100``, the source's high-expressiveness class);
* ``fluids_vector``: FLUIDS-Sensitivity-v3 (quasi-LIDAR vector, velocity level); BC, DAgger,
  DART with ``mlp`` and ``tree`` (``max_depth=10``, as the FLUIDS learning curves);
* ``fluids_birdseye``: the same id with ``obs_type="birdseye"`` (``birdseye_size`` 64 px); DAgger
  with ``cnn`` (a tree on 12,288 raw pixels is listed too, as the non-neural reference).

Every row is one training run of ``(setup, algorithm, learner, seed)``: its final normalised
performance, success rate (FLUIDS), training labels, fitting and total seconds, and the epochs
the network ran in its last fit. GridWorld's networks train long (300 epochs, patience 30): its
policy is a lookup over cells, and with ~10 validation pairs early stopping after 5 flat epochs
leaves the MLP underfit (train accuracy 0.76, normalised performance 0.09 where the same network
trained to fit its data reaches 1.0). Evaluation episodes are the harness's own seeded split (drawn
from the run's seed, never trained on). The networks train on 1 thread (``threads=1``): on a
shared 2-core machine that is the fastest setting for them, and it keeps the rows comparable.

``--budget short`` is a smoke-sized run (minutes, the numbers are noisy); ``--budget full``
is the intended baseline. Rows append to ``--out``.jsonl as each run finishes and a rerun skips
them (resumable); the table is written atomically to ``--out``.

    python scripts/baselines/neural_baselines.py --budget full --out docs/results/neural_baselines.json
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.learners.sklearn import PolicySpec
from fluids_bench.algos.registry import run_algorithm
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.jsonl import read_rows
from fluids_bench.core.provenance import announce, command_line, machine

FLUIDS = "FLUIDS-Sensitivity-v3"
SETUPS: dict[str, dict[str, Any]] = {
    "gridworld": {
        "env_id": "GridWorld-v0",
        "env_kwargs": {"world_seed": 3},
        "algos": ("bc", "dagger", "dart"),
        "learners": ("mlp", "tree"),
        "tree": {"max_depth": 100},
    },
    "fluids_vector": {
        "env_id": FLUIDS,
        "env_kwargs": {},
        "algos": ("bc", "dagger", "dart"),
        "learners": ("mlp", "tree"),
        "tree": {"max_depth": 10},
    },
    "fluids_birdseye": {
        "env_id": FLUIDS,
        "env_kwargs": {"obs_type": "birdseye", "birdseye_size": 64},
        "algos": ("dagger",),
        "learners": ("cnn", "tree"),
        "tree": {"max_depth": 10},
    },
}
# per budget and setup: run settings, and the networks' epochs / patience
BUDGETS: dict[str, dict[str, dict[str, Any]]] = {
    "short": {
        "gridworld": {"iterations": 3, "eval_episodes": 5, "seeds": 1, "epochs": 300, "patience": 30},
        "fluids_vector": {
            "iterations": 2, "eval_episodes": 3, "seeds": 1, "epochs": 10, "max_steps": 150,
        },
        "fluids_birdseye": {
            "iterations": 2, "eval_episodes": 2, "seeds": 1, "epochs": 5, "max_steps": 100,
        },
    },
    "full": {
        "gridworld": {"iterations": 20, "eval_episodes": 20, "seeds": 3, "epochs": 300, "patience": 30},
        "fluids_vector": {"iterations": 10, "eval_episodes": 20, "seeds": 3, "epochs": 50},
        "fluids_birdseye": {"iterations": 10, "eval_episodes": 10, "seeds": 1, "epochs": 20},
    },
}  # fmt: skip


def learner_for(setup: dict[str, Any], name: str, budget: dict[str, Any], seed: int) -> Any:
    if name == "tree":
        return PolicySpec("tree", setup["tree"])
    from fluids_bench.algos.learners.torch_nets import CNNLearner, MLPLearner

    common = {
        "epochs": budget["epochs"],
        "patience": budget.get("patience", 5),
        "seed": seed,
        "threads": 1,
    }
    if name == "mlp":
        return MLPLearner(hidden=(128, 128), **common)
    return CNNLearner(hidden=(128,), batch_size=32, **common)


def run_one(setup_name: str, algo: str, learner_name: str, seed: int, budget: dict) -> dict:
    setup = SETUPS[setup_name]
    learner = learner_for(setup, learner_name, budget, seed)
    settings: dict[str, Any] = {
        "env_id": setup["env_id"],
        "env_kwargs": setup["env_kwargs"],
        "iterations": budget["iterations"],
        "eval_episodes": budget["eval_episodes"],
        "eval_at": (),  # the last iteration only
        "max_steps": budget.get("max_steps"),
        "seed": seed,
        "policy": learner,
    }
    if setup["env_id"].startswith("FLUIDS"):
        settings["return_floor"] = -1.0  # progress minus collisions can be negative
    if algo == "dart":
        # GridWorld's 30-step episodes leave no pair over after 50 samples: hold out 10 %
        settings["update_at"] = tuple(range(1, budget["iterations"] + 1, 2))
        settings["heldout_fraction"] = 0.1
    start = time.perf_counter()
    result = run_algorithm(algo, **settings)
    seconds = time.perf_counter() - start
    final = result.final
    history = getattr(learner, "history", None)
    return {
        "setup": setup_name,
        "env_id": setup["env_id"],
        "env_kwargs": setup["env_kwargs"],
        "algo": algo,
        "learner": learner_name,
        "seed": seed,
        "normalised_performance": final.normalised_performance,
        "eval_return": final.eval_return,
        "supervisor_return": result.supervisor_return,
        "success_rate": final.eval_success_rate,
        "training_labels": final.training_labels,
        "train_seconds": final.train_seconds,
        "wall_seconds": final.wall_seconds,
        "seconds_with_evaluation": seconds,
        "last_fit": None if not history else history[-1],
    }


def summarise(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Mean over seeds per (setup, algo, learner)."""
    groups: dict[tuple[str, str, str], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["setup"], row["algo"], row["learner"]), []).append(row)
    out = []
    for (setup, algo, learner), members in sorted(groups.items()):
        perf = [
            r["normalised_performance"] for r in members if r["normalised_performance"] is not None
        ]
        success = [r["success_rate"] for r in members if r["success_rate"] is not None]
        out.append(
            {
                "setup": setup,
                "algo": algo,
                "learner": learner,
                "seeds": len(members),
                "normalised_performance": float(np.mean(perf)) if perf else None,
                "success_rate": float(np.mean(success)) if success else None,
                "training_labels": int(np.mean([r["training_labels"] for r in members])),
                "train_seconds": float(np.mean([r["train_seconds"] for r in members])),
                "seconds_with_evaluation": float(
                    np.sum([r["seconds_with_evaluation"] for r in members])
                ),
            }
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--budget", choices=sorted(BUDGETS), default="short")
    parser.add_argument("--setups", nargs="+", choices=sorted(SETUPS), default=sorted(SETUPS))
    parser.add_argument("--learners", nargs="+", default=None, help="subset of mlp, cnn, tree")
    parser.add_argument("--out", default="neural_baselines.json")
    args = parser.parse_args()
    announce(
        "short: ~10-20 min on 2 busy cores; full: several hours (see docs/algorithms.md)"
        if args.budget == "short"
        else "several hours on 2 cores"
    )
    log = f"{args.out}.jsonl"
    rows = read_rows(log)
    done = {(r["setup"], r["algo"], r["learner"], r["seed"]) for r in rows}
    started = {"command": command_line(), "machine": machine()}
    for setup_name in args.setups:
        setup, budget = SETUPS[setup_name], BUDGETS[args.budget][setup_name]
        for algo in setup["algos"]:
            for learner in setup["learners"]:
                if args.learners and learner not in args.learners:
                    continue
                for seed in range(budget["seeds"]):
                    if (setup_name, algo, learner, seed) in done:
                        continue
                    row = run_one(setup_name, algo, learner, seed, budget)
                    print(json.dumps({k: row[k] for k in list(row)[:12]}), flush=True)
                    with open(log, "a", encoding="utf-8") as handle:
                        handle.write(json.dumps(row) + "\n")
                    rows.append(row)
    write_json_atomic(
        args.out,
        {
            **started,
            "budget": args.budget,
            "settings": {name: BUDGETS[args.budget][name] for name in args.setups},
            "summary": summarise(rows),
            "rows": rows,
        },
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
