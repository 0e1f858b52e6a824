"""`fluids-bench sweep`: a sensitivity sweep of a policy over a grid of env configurations
(for FLUIDS the analysis of ch. 7, Fig. 7.6).

Evaluates a policy on every configuration of the grid (default: cars 2–5, pedestrians 0–4,
quasi-LIDAR noise and omission, lights, car mass; 256 configurations) with `--episodes`
seeded episodes each of FLUIDS-Sensitivity-v0, and plots the success rate (every car reaches
its goal) against each normalised parameter. Rows are stored as configurations finish: run the
same command again after an interruption and it resumes. Example:

    fluids-bench sweep --out out/sweep --episodes 20 --workers 2
    fluids-bench sweep --out out/small --values cars=2,5 --values pedestrians=0 --episodes 5
    fluids-bench sweep --env FLUIDS-Sensitivity-v1 --out out/sweep_v1 \
        --values car_mass=750,1500,3000 --check-episodes 100

Any registered id: `--env ID --values NAME=V1,V2` (repeatable) sweeps those keyword
arguments of the env (checked by the env itself before any work); without `--values` the id's
default sensitivity grid (`fluids_bench.sweep.grid.SENSITIVITY`). `--env-kwarg K=V` fixes a
kwarg for training and every test configuration; `--train-kwarg K=V` for training only:

    fluids-bench sweep --env Singulation-v0 --policy supervisor --out out/sing --episodes 10
    fluids-bench sweep --env DrivingTrack-v0 --env-kwarg obs_type=state --algo dagger \
        --iterations 3 --demos 5 --values edges=3,5,7 --values speed=7.5,10,12.5

The default policy is `--algo` (Behavior Cloning unless told) trained on `--demos`
supervisor demonstrations per iteration (trained once, cached in the output folder);
`--policy PATH` evaluates a pickled policy instead (anything with `act(observation)`;
pickles run code, load only your own), `--policy supervisor` the supervisor itself.
Besides the sensitivity PNG, a kwarg grid writes heatmaps for every pair of factors
(OUT/heatmaps.png) and a summary table (OUT/summary.md).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from fluids_bench.commands import plain_text
from fluids_bench.commands.arguments import key_value


def _values(text: str):
    from fluids_bench.sweep.grid import parse_values

    try:
        return parse_values(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from fluids_bench.sweep.grid import ORDER

    parser = subparsers.add_parser(
        "sweep",
        help="sensitivity sweep of a policy over scene parameters (resumable, PNG plot)",
        description=plain_text(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--out", type=Path, default=Path("out/sweep"), help="output folder")
    parser.add_argument(
        "--env",
        default="FLUIDS-Sensitivity-v0",
        help="a registered id (default FLUIDS-Sensitivity-v0, the source's setting; "
        "FLUIDS-Sensitivity-v1: defensive drivers, quasi-LIDAR v1, success obeys lights)",
    )
    parser.add_argument("--episodes", type=int, default=20, help="episodes per configuration")
    parser.add_argument(
        "--seed", type=int, default=0, help="sweep seed (episode seeds derive from it)"
    )
    parser.add_argument(
        "--values",
        action="append",
        type=_values,
        default=[],
        metavar="NAME=V1,V2",
        help=f"one factor's values: FLUIDS-Sensitivity ids replace one of {', '.join(ORDER)}; "
        "otherwise NAME is an env keyword argument and the --values given are the whole grid",
    )
    parser.add_argument(
        "--env-kwarg",
        action="append",
        type=key_value,
        default=[],
        metavar="K=V",
        help="env keyword argument fixed for training and every test configuration "
        "(kwarg grids only), e.g. obs_type=state",
    )
    parser.add_argument(
        "--algo",
        default="bc",
        help="algorithm of the default policy (bc, dagger, dart, shiv, ...; default bc)",
    )
    parser.add_argument(
        "--iterations", type=int, default=1, help="training iterations (default policy)"
    )
    parser.add_argument(
        "--policy",
        default=None,
        metavar="PATH",
        help="pickled policy to evaluate, or 'supervisor' (default: train BC, cached in --out)",
    )
    parser.add_argument(
        "--demos",
        type=int,
        default=100,
        help="supervisor demonstrations (per iteration) of the default policy",
    )
    parser.add_argument("--learner", default="tree", help="BC model family (default policy)")
    parser.add_argument("--train-seed", type=int, default=0, help="BC seed (default policy)")
    parser.add_argument(
        "--train-kwarg",
        action="append",
        type=key_value,
        default=[],
        metavar="K=V",
        help="env keyword argument for BC's demonstrations, e.g. lidar_noise=1 (an ablation; "
        "default: the env's own defaults)",
    )
    parser.add_argument(
        "--train-values",
        action="append",
        type=_values,
        default=[],
        metavar="NAME=V1,V2",
        help="train-on-grid / test-on-grid: train one policy per configuration of these env "
        "kwargs (repeatable), sweep each over the test grid in OUT/train_<k>/, and write "
        "OUT/matrix.json and OUT/matrix.md",
    )
    parser.add_argument(
        "--check-episodes",
        type=int,
        default=0,
        help="after training, the BC policy's success on this many episodes of its own "
        "training distribution (printed, and kept in OUT/policy.json)",
    )
    parser.add_argument(
        "--max-episode-steps",
        type=int,
        default=None,
        help="episode time limit in steps (default: 400 on the FLUIDS-Sensitivity ids, "
        "the registered limit elsewhere)",
    )
    parser.add_argument(
        "--workers", type=int, default=None, help="parallel workers (default: CPU count)"
    )
    parser.add_argument("--backend", choices=["process", "ray"], default="process")
    parser.add_argument(
        "--ray-address", default=None, help="Ray cluster address (default: start a local Ray)"
    )
    parser.add_argument("--plot", type=Path, default=None, help="PNG path (default OUT/sweep.png)")
    parser.add_argument("--overwrite", action="store_true", help="discard results in --out")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.set_defaults(func=run)


# fields the library's checks name -> the options that set them
SWEEP_OPTIONS = {
    "env": "--env",
    "env_kwarg": "--env-kwarg",
    "train_values": "--train-values",
}


def run(args: argparse.Namespace) -> int:
    from fluids_bench.commands.options import (
        check_int_option,
        check_workers_option,
        options_named,
        unique_keys,
    )
    from fluids_bench.sweep.grid import make_grid
    from fluids_bench.sweep.run import MAX_EPISODE_STEPS, check_env_id, probe_env

    check_int_option("--episodes", args.episodes, 1)
    check_int_option("--seed", args.seed, 0, 2**32 - 1)
    workers = (os.cpu_count() or 1) if args.workers is None else args.workers
    check_workers_option(workers, args.backend, args.ray_address)
    check_int_option("--check-episodes", args.check_episodes, 0)
    check_int_option("--iterations", args.iterations, 1)
    check_int_option("--demos", args.demos, 1)
    if args.max_episode_steps is not None:
        check_int_option("--max-episode-steps", args.max_episode_steps, 1)
    # a NAME given twice would keep its last values silently
    args.values = list(unique_keys("--values", args.values).items())
    args.train_values = list(unique_keys("--train-values", args.train_values).items())
    fixed = unique_keys("--env-kwarg", args.env_kwarg)
    unique_keys("--train-kwarg", args.train_kwarg)
    _check_policy_option(args.policy)
    import fluids_bench  # noqa: F401  (registers the ids)

    with options_named(SWEEP_OPTIONS):
        grid = make_grid(args.env, args.values)
        env_id = check_env_id(args.env, grid)
    if args.policy is None or args.policy == "supervisor":  # trained from it, or it is swept
        _check_supervised(env_id, fixed)
    if grid.legacy:
        max_steps = args.max_episode_steps or MAX_EPISODE_STEPS
        if args.env_kwarg:
            raise ValueError(
                "--env-kwarg is given with the FLUIDS-Sensitivity grid; allowed: only with "
                "--values over env keyword arguments"
            )
    else:
        max_steps = args.max_episode_steps
    both = sorted(set(fixed) & set(grid.names))
    if both:
        raise ValueError(f"--env-kwarg gives {both}, which --values varies; allowed: other kwargs")
    from fluids_bench.algos.registry import get_algorithm

    get_algorithm(args.algo)  # an unknown algorithm fails now
    probe_env(grid, env_id, fixed)  # a bad grid fails now, not in a worker
    if args.backend == "ray":
        try:
            from fluids_bench.core.parallel import import_ray

            import_ray()
        except ImportError as exc:  # the ray extra is missing
            print(f"fluids-bench sweep: error: {exc}", file=sys.stderr)
            return 2
    if args.train_values:
        return _run_matrix(args, grid, env_id, fixed, max_steps, workers)
    if (args.out / MATRIX).exists() or any(args.out.glob("train_*/manifest.json")):
        raise FileExistsError(f"{args.out} holds a train-on-grid matrix; use another --out folder")
    _run_one(args, grid, env_id, fixed, max_steps, workers)
    return 0


MATRIX = "matrix.json"


def _check_supervised(env_id: str, fixed: dict) -> None:
    """The env must have a supervisor when the sweep trains from it or sweeps it: refused now,
    not as a traceback in a worker."""
    import gymnasium as gym

    from fluids_bench.commands.options import check_supervised

    env = gym.make(env_id, **fixed)
    try:
        check_supervised("--env", env_id, env)
    finally:
        env.close()


def _check_policy_option(policy: str | None) -> None:
    """`--policy` must be 'supervisor' or a file holding a pickled policy: refused now, in one
    line, not as a traceback after training starts."""
    from fluids_bench.sweep.run import SUPERVISOR_POLICY, load_policy

    if policy is None or policy == SUPERVISOR_POLICY:
        return
    allowed = f"allowed: {SUPERVISOR_POLICY!r} or a pickled policy with act(observation)"
    path = Path(policy)
    if not path.is_file():
        what = "a folder" if path.is_dir() else "no such file"
        raise ValueError(f"--policy is {policy!r}, {what}; {allowed}")
    try:
        load_policy(path)
    except ValueError as exc:  # unpickled something without act()
        raise ValueError(f"--policy is {policy!r}: {exc}; {allowed}") from None
    except Exception as exc:  # whatever unpickling garbage raises (UnpicklingError, EOFError...)
        raise ValueError(
            f"--policy is {policy!r}, not a readable pickle ({type(exc).__name__}: {exc}); "
            f"{allowed}"
        ) from None


def _run_matrix(args, grid, env_id, fixed, max_steps, workers) -> int:
    """Train one policy per configuration of the `--train-values` grid and sweep each over the
    test grid, in OUT/train_<k>/; then OUT/matrix.json and OUT/matrix.md."""
    import copy
    import json

    from fluids_bench.algos.results import write_bytes_atomic, write_json_atomic
    from fluids_bench.sweep.grid import KwargGrid
    from fluids_bench.sweep.plot import metric_for, summary
    from fluids_bench.sweep.run import probe_env

    if grid.legacy:
        raise ValueError(
            "sweep: field 'train_values' is given with the FLUIDS-Sensitivity grid; allowed: "
            "only with --values over env keyword arguments"
        )
    if args.policy is not None:
        raise ValueError(
            f"sweep: field 'train_values' is given with --policy {args.policy}; allowed: only "
            "with a policy the sweep trains (--algo)"
        )
    if (args.out / "manifest.json").exists():
        raise FileExistsError(f"{args.out} holds a single sweep; use another --out folder")
    train_grid = KwargGrid(dict(args.train_values))
    base = {**fixed, **dict(args.train_kwarg)}
    probe_env(train_grid, env_id, base)  # every training value checked by the env first
    entries = []
    for k, config in train_grid.configurations():
        print(f"training configuration {k + 1} of {len(train_grid)}: {config}")
        one = copy.copy(args)
        one.out = args.out / f"train_{k}"
        one.plot = None
        one.train_kwarg = [*args.train_kwarg, *config.items()]
        rows = _run_one(one, grid, env_id, fixed, max_steps, workers)
        data = summary(rows, grid, metric_for(one.out, env_id))
        entries.append({"train": config, "folder": one.out.name, "summary": data})
    matrix = {
        "env_id": env_id,
        "train_grid": train_grid.to_dict(),
        "test_grid": grid.to_dict(),
        "train_kwargs": base,
        "entries": entries,
    }
    write_json_atomic(args.out / MATRIX, json.loads(json.dumps(matrix)))
    write_bytes_atomic(args.out / "matrix.md", _matrix_markdown(matrix).encode())
    print(f"wrote {args.out / MATRIX} and {args.out / 'matrix.md'}")
    return 0


def _matrix_markdown(matrix) -> str:
    """One table per factor both grids vary: training value(s) × test level; and the overall
    metric of every training configuration."""
    entries = matrix["entries"]
    metric = entries[0]["summary"]["metric"] if entries else "success"
    name = "success rate" if metric == "success" else "normalised return"
    lines = [f"Overall {name} of each training configuration over the whole test grid:", ""]
    lines += ["| trained on | overall |", "|---|---|"]
    for e in entries:
        lines.append(f"| {_kwargs_text(e['train'])} | {e['summary']['overall']:.3f} |")
    for factor, levels in matrix["test_grid"].items():
        if factor not in matrix["train_grid"]:
            continue
        lines += ["", f"{name} by the test value of `{factor}` (rows: trained on):", ""]
        lines.append("| trained on | " + " | ".join(str(v) for v in levels) + " |")
        lines.append("|---|" + "---|" * len(levels))
        for e in entries:
            by_level = {str(x["value"]): x for x in e["summary"]["factors"][factor]}
            cells = [
                f"{by_level[str(v)]['metric']:.3f} ± {by_level[str(v)]['stderr']:.3f}"
                if str(v) in by_level
                else ""
                for v in levels
            ]
            lines.append(f"| {_kwargs_text(e['train'])} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _kwargs_text(kwargs) -> str:
    return ", ".join(f"{k}={v}" for k, v in kwargs.items())


def _run_one(args, grid, env_id, fixed, max_steps, workers) -> list:
    """Train (or load) the policy, sweep it over `grid` into `args.out`, write the plots;
    the rows."""
    from tqdm.auto import tqdm

    from fluids_bench.sweep.plot import SUCCESS, metric_for, plot_sensitivity, write_kwarg_outputs
    from fluids_bench.sweep.run import (
        SUPERVISOR_POLICY,
        check_folder_for_new_policy,
        load_policy,
        run_sweep,
        train_default_policy,
    )

    args.out.mkdir(parents=True, exist_ok=True)
    if args.policy == SUPERVISOR_POLICY:
        policy = policy_bytes = None

    else:
        path = Path(args.policy) if args.policy else None
        if path is None:

            def before_training() -> None:  # refuse a folder of another sweep before training
                if not args.overwrite:
                    check_folder_for_new_policy(
                        args.out, grid, args.episodes, args.seed, max_steps, env_id, fixed
                    )
                print(
                    f"training the default policy: {args.algo} (--demos {args.demos}, "
                    f"--iterations {args.iterations})"
                )

            path = train_default_policy(
                args.out,
                demos=args.demos,
                learner=args.learner,
                seed=args.train_seed,
                replace=args.overwrite,
                before_training=before_training,
                env_id=env_id,
                check_episodes=args.check_episodes,
                train_kwargs={**fixed, **dict(args.train_kwarg)},
                algo=args.algo,
                iterations=args.iterations,
            )
            _print_check(args.out)
        policy, policy_bytes = load_policy(path)
    plot_path = args.plot or args.out / "sweep.png"
    bars = []
    counts = {"episodes": 0, "successes": 0, "cpu": 0.0}
    started = time.perf_counter()

    def on_start(done: int, total: int) -> None:
        if done:
            print(f"resuming: {done} of {total} configurations already in {args.out}")
        # initial=done: the rate and the ETA count only configurations run now
        bars.append(
            tqdm(total=total, initial=done, unit="config", desc="sweep", disable=args.no_progress)
        )

    def on_row(row) -> None:
        counts["episodes"] += row["episodes"]
        counts["successes"] += row["successes"]
        counts["cpu"] += row["cpu_seconds"]
        bar = bars[0]
        bar.update(1)
        bar.set_postfix(success=f"{counts['successes'] / counts['episodes']:.2f}", refresh=False)

    try:
        rows = run_sweep(
            args.out,
            grid,
            policy,
            policy_bytes,
            episodes=args.episodes,
            seed=args.seed,
            max_episode_steps=max_steps,
            backend=args.backend,
            workers=workers,
            address=args.ray_address,
            overwrite=args.overwrite,
            on_start=on_start,
            on_row=on_row,
            env_id=env_id,
            fixed=fixed,
        )
    finally:
        for bar in bars:
            bar.close()
    seconds = time.perf_counter() - started
    metric = metric_for(args.out, env_id)
    plot_sensitivity(rows, grid, plot_path, metric=metric)
    extra = write_kwarg_outputs(rows, grid, args.out, env_id) if not grid.legacy else []
    episodes = sum(r["episodes"] for r in rows)
    successes = sum(r["successes"] for r in rows)
    returns = (
        ""
        if grid.legacy
        else f", mean return {sum(r['mean_return'] for r in rows) / len(rows):.3f}"
    )
    # an id without a success flag (metric "return") has no success rate to report
    rate = f", success rate {successes / episodes:.3f}" if metric == SUCCESS else ""
    print(
        f"{len(rows)} configurations, {episodes} episodes{rate}{returns}; "
        f"this run: {counts['episodes']} episodes in {seconds:.1f} s wall, "
        f"{counts['cpu']:.1f} s CPU in the workers ({workers} {args.backend} workers)"
    )
    print(f"wrote {', '.join(str(p) for p in [args.out / 'results.csv', plot_path, *extra])}")
    return rows


def _print_check(folder: Path) -> None:
    import json

    info = json.loads((folder / "policy.json").read_text())
    check = info.get("in_distribution")
    if check:
        print(
            f"BC in distribution: {check['successes']}/{check['episodes']} successes "
            f"({check['collisions']} collisions, {check['timeouts']} timeouts)"
        )
