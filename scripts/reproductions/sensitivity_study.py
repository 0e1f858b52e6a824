"""Sensitivity studies on every task family: the supervisor, Behavior Cloning and DAgger over a
3 x 3 x 3 grid of each task's perturbation kwargs (the question of the source's Fig. 7.6), and
over the Singulation objects' size alone (``singulation_size``).

For each task, three resumable ``fluids-bench sweep`` runs in ``--out/<task>/``: ``supervisor``
(the reference), ``bc`` (a decision tree trained on the task's number of supervisor
demonstrations of the nominal configuration: the registered defaults plus the study's fixed
kwargs) and ``dagger`` (a decision tree, one demonstration then 4 iterations of a quarter of that
number of on-policy rollouts, labelled by the supervisor, on the same configuration), each then
tested on every configuration. Writes ``docs/results/sweep_<task>.json`` (``--results-dir``): the
settings, the command, every row, and per-factor summaries (success rate, or the return
normalised by the best configuration's where the env reports no success) with standard errors;
and the figure ``docs/images/sweep_<task>.png`` (``--images-dir``): each policy's level
estimates ± standard error against each factor. ``--figures-only`` redraws the figures from
the results files without sweeping.

    python scripts/reproductions/sensitivity_study.py --tasks singulation track hopper --workers 2
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import json
import shlex
import sys
import time
from pathlib import Path

import gymnasium as gym

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.cli import main as cli
from fluids_bench.sweep.compare import nominal_row, plot_policies
from fluids_bench.sweep.grid import KwargGrid
from fluids_bench.sweep.plot import RETURN, metric_for, summary
from fluids_bench.sweep.store import load_rows

# task -> (id, fixed env kwargs, grid, BC demonstrations[, episode step limit])
STUDIES = {
    "singulation": (
        "Singulation-v0",
        {},
        {
            "mass_ratio": (1.0, 4.0, 16.0),
            "friction_scale": (0.5, 1.0, 2.0),
            "cluster_std": (0.0, 0.0447, 0.09),
        },
        20,
    ),
    "track": (
        "DrivingTrack-v0",
        {"obs_type": "state"},
        {"edges": (3, 5, 7), "half_width": (10.0, 15.0, 20.0), "speed": (7.5, 10.0, 12.5)},
        20,
    ),
    "hopper": (
        "Hopper-IL-v0",
        {},
        {
            "body_mass_scale": (0.75, 1.0, 1.25),
            "friction_scale": (0.5, 1.0, 2.0),
            "actuator_gain_scale": (0.75, 1.0, 1.25),
        },
        10,
    ),
    # the objects' size on its own, the learners trained with the settings of "singulation"
    "singulation_size": ("Singulation-v0", {}, {"object_size_scale": (0.75, 1.0, 1.25)}, 20),
    # GridWorld: the world (goal, penalties) is drawn from world_seed for each size; at one
    # size more penalty_fraction adds penalty cells to the same world
    "gridworld": (
        "GridWorld-v0",
        {},
        {
            "size": (10, 15, 20),
            "slip_probability": (0.0, 0.16, 0.32),
            "penalty_fraction": (0.04, 0.08, 0.16),
        },
        20,
    ),
    # three of the default grid's four factors (friction rather than the target's spread)
    "grasping": (
        "GraspingInClutter-v0",
        {},
        {
            "obstacles": (1, 3, 5),
            "obstacle_size_scale": (0.75, 1.0, 1.25),
            "friction": (0.25, 0.5, 1.0),
        },
        20,
    ),
    # Fig. 7.6's setting on the fair benchmark: BC as the Fig. 7.6 page trains it (a tree on
    # 100 demonstrations), episodes of up to 400 steps as that sweep's
    "fluids": (
        "FLUIDS-Sensitivity-v1",
        {},
        {
            "num_cars": (1, 3, 4),
            "lidar_noise": (0.0, 0.5, 1.0),
            "car_mass": (750.0, 1500.0, 3000.0),
        },
        100,
        400,
    ),
}
# minutes for 10 episodes a configuration with 2 workers
EXPECTED_MINUTES = {
    "singulation": 1.0,
    "singulation_size": 0.1,
    "track": 0.5,
    "hopper": 1.8,
    "gridworld": 0.2,
    "grasping": 2.0,
    "fluids": 5.0,
}


def nominal_configuration(env_id: str, names, fixed: dict) -> dict:
    """Each factor's nominal value: the fixed kwargs, else the registration's, else the env's
    own default."""
    spec = gym.spec(env_id)
    module, _, name = spec.entry_point.partition(":")
    signature = inspect.signature(getattr(importlib.import_module(module), name))
    defaults = {k: p.default for k, p in signature.parameters.items()}
    merged = {**defaults, **spec.kwargs, **fixed}
    return {name: merged[name] for name in names}


def draw_figure(task: str, data: dict, images_dir: Path) -> Path:
    """docs/images/sweep_<task>.png from a study's results."""
    grid = KwargGrid({k: tuple(v) for k, v in data["grid"].items()})
    policies = {p: entry["rows"] for p, entry in data["policies"].items()}
    reference = None
    if data["metric"] == RETURN:  # returns on the supervisor's scale at the nominal config
        nominal = data.get("nominal") or nominal_configuration(
            data["env_id"], grid.names, data["fixed_kwargs"]
        )
        reference = float(nominal_row(policies["supervisor"], nominal)["mean_return"])
    path = images_dir / f"sweep_{task}.png"
    n = len(data["policies"]["supervisor"]["rows"])
    title = f"{data['env_id']}: {n} configurations × {data['episodes']} episodes"
    plot_policies(policies, grid, data["metric"], path, reference, title)
    return path


def run_task(task: str, args: argparse.Namespace) -> dict:
    env_id, fixed, grid_values, demos, *limit = STUDIES[task]
    base = ["sweep", "--env", env_id, "--episodes", str(args.episodes), "--seed", str(args.seed)]
    base += ["--workers", str(args.workers), "--no-progress"]
    if limit:
        base += ["--max-episode-steps", str(limit[0])]
    for name, values in grid_values.items():
        base += ["--values", f"{name}={','.join(str(v) for v in values)}"]
    for key, value in fixed.items():
        base += ["--env-kwarg", f"{key}={value}"]
    grid = KwargGrid(grid_values)
    out: dict = {
        "env_id": env_id,
        "fixed_kwargs": fixed,
        "grid": grid.to_dict(),
        "episodes": args.episodes,
        "seed": args.seed,
        **({"max_episode_steps": limit[0]} if limit else {}),
        "nominal": nominal_configuration(env_id, grid.names, fixed),
        "policies": {},
    }
    trained = {
        "supervisor": ["--policy", "supervisor"],
        "bc": ["--demos", str(demos)],
        "dagger": ["--algo", "dagger", "--iterations", "4", "--demos", str(demos // 4)],
    }
    for policy, extra in trained.items():
        started = time.perf_counter()
        folder = args.out / task / policy
        if cli([*base, "--out", str(folder), *extra]) != 0:
            raise SystemExit(f"the {task} {policy} sweep failed")
        rows = load_rows(folder)
        metric = metric_for(folder, env_id)
        out["metric"] = metric
        out["policies"][policy] = {
            "summary": summary(rows, grid, metric),
            "rows": rows,
            "seconds": round(time.perf_counter() - started, 1),
            **({"demonstrations": demos, "learner": "tree"} if policy == "bc" else {}),
            **(
                {"initial_demos": 1, "iterations": 4, "rollouts_per_iteration": demos // 4}
                if policy == "dagger"
                else {}
            ),
        }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", choices=sorted(STUDIES), default=sorted(STUDIES))
    parser.add_argument("--episodes", type=int, default=10, help="episodes per configuration")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("out/sensitivity_study"))
    parser.add_argument("--results-dir", type=Path, default=Path("docs/results"))
    parser.add_argument("--images-dir", type=Path, default=Path("docs/images"))
    parser.add_argument(
        "--figures-only", action="store_true", help="redraw the figures from the results files"
    )
    args = parser.parse_args()
    if args.figures_only:
        for task in args.tasks:
            data = json.loads((args.results_dir / f"sweep_{task}.json").read_text())
            print(f"wrote {draw_figure(task, data, args.images_dir)}", flush=True)
        return
    minutes = sum(EXPECTED_MINUTES[t] for t in args.tasks) * args.episodes / 10
    print(f"expected run time: ~{max(minutes, 1):.0f} min on 2 cores", flush=True)
    command = "python " + shlex.join(["scripts/reproductions/sensitivity_study.py", *sys.argv[1:]])
    for task in args.tasks:
        started = time.perf_counter()
        data = run_task(task, args)
        data["command"] = command
        data["seconds"] = round(time.perf_counter() - started, 1)
        data["machine"] = "2-core CI-class machine, shared"
        write_json_atomic(args.results_dir / f"sweep_{task}.json", data)
        print(f"wrote {args.results_dir / f'sweep_{task}.json'} ({data['seconds']} s)", flush=True)
        print(f"wrote {draw_figure(task, data, args.images_dir)}", flush=True)


if __name__ == "__main__":
    main()
