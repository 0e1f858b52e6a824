"""DAgger against BC on FLUIDS-v4, with the Markov label and the plan-carrying one, as JSON.

For each planner period of ``--periods`` (1: FLUIDS-v4's own, the velocity planner at every
step, so the label is Markov; 5: v0-v3's, the planner's targets held for 5 steps) and each
training seed of ``--seeds``, runs BC and DAgger as ``fluids-bench train`` does
(`fluids_bench.algos`: a regression tree, every state of every rollout kept,
``--iterations`` rounds of one rollout each; DAgger starts from one supervisor demonstration and
rolls its learner out with beta = 0). Each final learner is then evaluated on the first
``--episodes`` seeds of the validation split (`fluids_bench.core.splits`): success (Wilson
95 % interval), driving score and route completion (95 % bootstrap intervals), infractions,
episode length; and the run's labels and its rollouts' lengths and ends.

Along DAgger's evaluation episodes it also counts, at every visited state, whether the ego is
on a recovery path (the Dubins path back to its route that the supervisor planned when the car
left the route: part of the world's state, so a restored or rebuilt supervisor keeps it), and
whether the label differs by more than ``RECOVERY_TOLERANCE`` m from the label of a supervisor
that replans from the car's pose and route alone (`replanned_label`).

Rows (one per period, seed and algorithm) append to ``OUT.jsonl`` as they finish and a rerun
skips them; ``--results FILE`` writes the summary, command and settings atomically.

    PYTHONPATH=. nice -n 10 python scripts/checks/dagger_fluids_v4.py --seeds 0 1 2 \\
        --iterations 20 --episodes 40 --out runs/dagger_v4 \\
        --results docs/results/fluids_v4_dagger_ablation.json
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import platform
import shlex
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos import bc, dagger
from fluids_bench.algos.actors import LearnerActor
from fluids_bench.algos.learners.sklearn import PolicySpec
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.algos.rollout import rollout
from fluids_bench.benchmark.metrics import interval
from fluids_bench.core.jsonl import read_rows
from fluids_bench.core.provenance import relative_paths
from fluids_bench.core.splits import split_seeds
from fluids_bench.tasks.fluids.core import actions, labels
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "quality"))
from supervisor_quality import wilson  # noqa: E402

ENV_ID = "FLUIDS-v4"
RECOVERY_TOLERANCE = 0.5  # m: a label further than this from the replanned one differs


def replanned_label(inner) -> np.ndarray:
    """The ego's label from a supervisor that keeps no plan at all: a copy of the world with
    the ego back on its route's own path (at its current route position, projected), and a
    new supervisor that prepares it (so it plans a new recovery path if the car is off the
    route, from where the car is now)."""
    world = copy.deepcopy(inner.world)
    route_s = float(world.s[0] + world.offset[0])
    world.follow_route(0, int(world.route[0]))
    world.s[0], world.offset[0], world.recovering[0] = route_s, 0.0, False
    world._update_progress()
    supervisor = DrivingSupervisor(world, inner.supervisor_config)
    supervisor.prepare(world)
    return labels.label(supervisor, world, inner.action_level, 0, inner.action_scale)


class RecoveryProbe:
    """The learner acting, recording at each state whether the ego is on a recovery path and
    how far its label is from `replanned_label` (m)."""

    def __init__(self, env: gym.Env, policy) -> None:
        self.inner, self.policy = env.unwrapped, policy
        self.recovering = self.states = self.differs = 0

    def __call__(self, observation, label, rng):
        self.states += 1
        if self.inner.world.recovering[0]:
            self.recovering += 1
            gap = np.max(np.abs(replanned_label(self.inner) - label)) * actions.WAYPOINT_BOUND
            self.differs += bool(gap > RECOVERY_TOLERANCE)
        return self.policy.act(observation)


def _ends(trajectories) -> dict:
    """How a run's rollouts ended: count, mean length, successes, infractions."""
    infos = [t.infos[-1] for t in trajectories]
    return {
        "rollouts": len(trajectories),
        "mean_steps": float(np.mean([len(t) for t in trajectories])),
        "successes": sum(bool(i.get("is_success", False)) for i in infos),
        "offroad": sum(i["infractions"]["offroad"] for i in infos),
        "collisions": sum(
            i["infractions"]["vehicle_collisions"] + i["infractions"]["pedestrian_collisions"]
            for i in infos
        ),
    }


def train_and_evaluate(algo: str, period: int, seed: int, iterations: int, episodes: int):
    kwargs = {} if period == 1 else {"planner_period": period}
    common = dict(
        env_id=ENV_ID,
        env_kwargs=kwargs,
        policy=PolicySpec(name="tree"),
        iterations=iterations,
        samples_per_demo=None,
        eval_episodes=5,
        eval_at=(),
        seed=seed,
    )
    module, config = (
        (bc, bc.BCConfig(**common)) if algo == "bc" else (dagger, dagger.DAggerConfig(**common))
    )
    started = time.process_time()
    result = module.run(config)
    train_cpu = time.process_time() - started
    env = gym.make(ENV_ID, **kwargs)
    probe = RecoveryProbe(env, result.policy)
    actor = probe if algo == "dagger" else LearnerActor(result.policy)
    episodes_out = [rollout(env, actor, s) for s in split_seeds("validation", episodes)]
    infos = [t.infos[-1] for t in episodes_out]
    last = result.records[-1]
    row = {
        "period": period,
        "seed": seed,
        "algo": algo,
        "labels": last.training_labels,
        "rollouts": last.demonstrations,
        "train_eval_success": last.eval_success_rate,
        "train_cpu_seconds": round(train_cpu, 1),
        "success": [bool(i.get("is_success", False)) for i in infos],
        "driving_score": [float(i["driving_score"]) for i in infos],
        "route_completion": [float(i["route_completion"]) for i in infos],
        "steps": [len(t) for t in episodes_out],
        "infractions": {
            k: sum(i["infractions"][k] for i in infos) for k in infos[0]["infractions"]
        },
    }
    if algo == "dagger":
        row["probe"] = {
            "states": probe.states,
            "recovering": probe.recovering,
            "label_differs_from_replanned": probe.differs,
        }
    env.close()
    return row


def summarise(rows: list[dict]) -> dict:
    """Per period and algorithm, over its training seeds' evaluation episodes pooled."""
    out: dict = {}
    for period in sorted({r["period"] for r in rows}):
        for algo in ("bc", "dagger"):
            mine = [r for r in rows if r["period"] == period and r["algo"] == algo]
            if not mine:
                continue
            success = [s for r in mine for s in r["success"]]
            wins = sum(success)
            entry = {
                "training_seeds": [r["seed"] for r in mine],
                "episodes": len(success),
                "success_rate": wins / len(success),
                "success_ci": list(wilson(wins, len(success))),
                "success_per_seed": [float(np.mean(r["success"])) for r in mine],
                "labels_per_seed": [r["labels"] for r in mine],
            }
            for key in ("driving_score", "route_completion"):
                mean, low, high = interval([v for r in mine for v in r[key]])
                entry[key], entry[f"{key}_ci"] = mean, [low, high]
                entry[f"{key}_per_seed"] = [float(np.mean(r[key])) for r in mine]
            entry["mean_steps"] = float(np.mean([v for r in mine for v in r["steps"]]))
            names = mine[0]["infractions"]
            entry["infractions"] = {k: sum(r["infractions"][k] for r in mine) for k in names}
            if algo == "dagger":
                entry["probe"] = {k: sum(r["probe"][k] for r in mine) for k in mine[0]["probe"]}
            out.setdefault(str(period), {})[algo] = entry
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--periods", type=int, nargs="+", default=[1, 5])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--iterations", type=int, default=20)
    parser.add_argument("--episodes", type=int, default=40, help="validation episodes")
    parser.add_argument("--out", default=None, help="rows in OUT.jsonl (resumable)")
    parser.add_argument("--results", default=None, help="summary JSON (written atomically)")
    args = parser.parse_args()
    runs = len(args.periods) * len(args.seeds) * 2
    print(f"expected run time: ~{round(runs * (args.iterations + args.episodes) * 2 / 60)} min on "
          "one busy core", flush=True)  # fmt: skip
    started = time.time()
    log = f"{args.out}.jsonl" if args.out else None
    settings = {"iterations": args.iterations, "episodes": args.episodes}
    rows = [r for r in read_rows(log) if r.get("settings") == settings]
    done = {(r["period"], r["seed"], r["algo"]) for r in rows}
    for seed in args.seeds:  # seed first: a run cut short still compares both periods
        for period in args.periods:
            for algo in ("bc", "dagger"):
                if (period, seed, algo) in done:
                    continue
                row = train_and_evaluate(algo, period, seed, args.iterations, args.episodes)
                row["settings"] = settings
                rows.append(row)
                print(json.dumps({k: v for k, v in row.items() if not isinstance(v, list)}),
                      flush=True)  # fmt: skip
                if log:
                    with open(log, "a") as f:
                        f.write(json.dumps(row) + "\n")
                        f.flush()
                        os.fsync(f.fileno())
    rows = [r for r in rows if r["period"] in args.periods and r["seed"] in args.seeds]
    seeds = split_seeds("validation", args.episodes)
    report = summarise(rows)
    print(json.dumps(report, indent=1))
    if args.results:
        write_json_atomic(
            args.results,
            {
                "command": "python scripts/checks/dagger_fluids_v4.py "
                + " ".join(shlex.quote(a) for a in relative_paths(sys.argv[1:])),
                "env_id": ENV_ID,
                "settings": {
                    **settings,
                    "policy": "tree",
                    "samples_per_demo": "all",
                    "dagger": "1 initial demonstration, beta 0, one rollout per iteration",
                    "bc": "one demonstration per iteration",
                    "validation_seeds": [seeds[0], seeds[-1]],
                    "recovery_tolerance_m": RECOVERY_TOLERANCE,
                },
                "machine": {
                    "processor": platform.processor() or platform.machine(),
                    "cpu_count": os.cpu_count(),
                },
                "wall_seconds": round(time.time() - started, 1),
                "results": report,
                "runs": [{k: v for k, v in r.items() if k != "settings"} for r in rows],
            },
        )


if __name__ == "__main__":
    main()
