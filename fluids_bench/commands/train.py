"""`fluids-bench train`: run one imitation-learning algorithm on one env, save JSON and a PNG.

The JSON is rewritten (atomically) as each iteration finishes, marked `"complete": false`
until the run ends: an interrupted run (Ctrl-C) keeps the records of its finished iterations
and says where. Every finished rollout and evaluation is kept in OUT/<run>.checkpoint/ until
the run completes; the same command with `--resume` continues from there (without it, a run
starts again from the beginning).

The rollouts of an iteration and the evaluation episodes run on `--workers` processes, or
as Ray tasks with `--backend ray`; the learner is fitted in this process. The records are
the same whatever the workers and the backend. `--policy module:factory` trains any learner
(an object with fit/predict; `--policy-param` are the factory's keyword arguments); a learner
with a `save` method (the torch ones) is written to OUT/<run>.learner.npz at the end, which
`fluids_bench.algos.learners.load_learner` reads. Example:

    fluids-bench train --env GridWorld-v0 --algo dagger --policy linear_svm \\
        --env-kwarg world_seed=3 --iterations 20 --out out/train --workers 2
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import shutil
import sys
from pathlib import Path
from typing import Any

from fluids_bench.commands import plain_text
from fluids_bench.commands.arguments import key_value

# option -> (config field, type, help); the field decides which algorithms accept it
ALGO_OPTIONS: dict[str, tuple[str, Any, str]] = {
    "--beta": ("beta", float, "dagger: probability of executing the supervisor's action"),
    "--beta-schedule": ("beta_schedule", str, "dagger: constant or exponential (beta^k)"),
    "--initial-demos": (
        "initial_demos",
        int,
        "dagger, shiv: supervisor demos first; dart: demos under the initial noise first",
    ),
    "--retrain-at": ("retrain_at", int, "dagger_b: iterations after which to refit (list)"),
    "--retrain-every": ("retrain_every", int, "dagger_b: refit every k iterations"),
    "--noise-std": ("noise_std", float, "noise: Gaussian std for Box actions"),
    "--epsilon": (
        "epsilon",
        float,
        "noise: chance of another action (Discrete); shiv: allowed L2 error (Box)",
    ),
    "--alpha": ("alpha", float, "dart: target trace of the noise covariance (Box)"),
    "--alpha-relative": (
        "alpha_relative",
        float,
        "dart: target trace as a multiple of an estimate's trace (the source's 'alpha = 3')",
    ),
    "--alpha-reference": ("alpha_reference", str, "dart: first or current estimate"),
    "--update-at": ("update_at", int, "dart: iterations after which to refit the noise (list)"),
    "--update-every": ("update_every", int, "dart: refit the noise every k iterations"),
    "--heldout-fraction": ("heldout_fraction", float, "dart: share of each demo held out"),
    "--initial-noise-std": ("initial_noise_std", float, "dart: noise of the first demos (Box)"),
    "--initial-epsilon": ("initial_epsilon", float, "dart: noise of the first demos (Discrete)"),
    "--selector": ("selector", str, "shiv: shiv, novelty, confidence, qbc or mmd"),
    "--nu": ("nu", float, "shiv: One-Class SVM nu of the well-predicted states"),
    "--sigma": (
        "sigma",
        float,
        "shiv: kernel bandwidth of the well-predicted states, raw units (default: median "
        "heuristic on standardised features)",
    ),
    "--nu-r": ("nu_r", float, "shiv: One-Class SVM nu of the mispredicted states"),
    "--sigma-r": ("sigma_r", float, "shiv: kernel bandwidth of the mispredicted states"),
    "--learning-rate": ("learning_rate", float, "ogd: gradient step size eta"),
    "--steps-per-iteration": ("steps_per_iteration", int, "ogd: gradient steps per iteration"),
}
LIST_FIELDS = {"retrain_at", "update_at"}
# `fluids_bench.algos.policies.FAMILIES`, spelled out so that building the parser does not
# import scikit-learn (tests/algos/test_train_cli.py checks that the two agree)
POLICY_FAMILIES = (
    "kernel_ridge",
    "knn",
    "linear_svm",
    "linear_svm_span",
    "mlp",
    "tree",
    "constant",
)


def _samples(text: str) -> int | None:
    return None if text == "all" else int(text)


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "train",
        help="run an imitation-learning algorithm on an env; write JSON results and a PNG",
        description=plain_text(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--env", required=True, help="env id, e.g. GridWorld-v0, DAG-v0")
    parser.add_argument(
        "--algo", required=True, help="bc, dagger, dagger_b, noise, dart, shiv, ogd"
    )
    parser.add_argument("--env-kwarg", action="append", type=key_value, default=[], metavar="K=V")
    parser.add_argument(
        "--policy",
        default="tree",
        help=f"a scikit-learn family ({', '.join(POLICY_FAMILIES)}; default: tree), or "
        "module:factory, a callable returning a learner (fit/predict), e.g. "
        "fluids_bench.algos.learners:MLPLearner; --policy-param K=V are its keyword arguments",
    )
    parser.add_argument(
        "--policy-param", action="append", type=key_value, default=[], metavar="K=V"
    )
    parser.add_argument("--iterations", type=int, default=10)
    parser.add_argument("--demos-per-iteration", type=int, default=1)
    parser.add_argument("--samples-per-demo", type=_samples, default=50, help="int or 'all'")
    parser.add_argument("--eval-episodes", type=int, default=10)
    parser.add_argument("--eval-every", type=int, default=1)
    parser.add_argument(
        "--eval-at", type=int, nargs="*", default=None, help="iterations to evaluate at (list)"
    )
    parser.add_argument("--max-steps", type=int, default=None)
    parser.add_argument("--return-floor", type=float, default=0.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("out/train"), help="output folder")
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    parser.add_argument(
        "--workers",
        type=int,
        default=1,
        help="rollouts run in parallel: processes, or Ray tasks at a time (default 1: here)",
    )
    parser.add_argument("--backend", choices=["process", "ray"], default="process")
    parser.add_argument(
        "--ray-address", default=None, help="Ray cluster address (default: start a local Ray)"
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted run of the same command from OUT/<run>.checkpoint/",
    )
    parser.add_argument(
        "--x-axis",
        choices=("training_labels", "demonstrations", "labels_requested"),
        default="training_labels",
        help="learning-curve x-axis (the source: demonstrations at the trajectory level, "
        "training labels at the state level)",
    )
    group = parser.add_argument_group("algorithm options (only for the algorithms named)")
    for option, (dest, kind, text) in ALGO_OPTIONS.items():
        nargs = "+" if dest in LIST_FIELDS else None
        group.add_argument(option, dest=dest, type=kind, nargs=nargs, default=None, help=text)
    parser.set_defaults(func=main)


def build_config(args: argparse.Namespace) -> tuple[str, Any]:
    """The algorithm's name and validated config from parsed arguments."""
    from fluids_bench.algos.registry import ALGORITHMS, get_algorithm
    from fluids_bench.commands.options import (
        check_gym_id,
        check_workers_option,
        options_named,
        unique_keys,
    )

    algorithm = get_algorithm(args.algo)
    fields = {f.name for f in dataclasses.fields(algorithm.config_class)}
    settings: dict[str, Any] = dict(algorithm.presets)
    for option, (dest, _, _) in ALGO_OPTIONS.items():
        value = getattr(args, dest)
        if value is None:
            continue
        if dest not in fields:
            takers = sorted(
                name
                for name, algo in ALGORITHMS.items()
                if dest in {f.name for f in dataclasses.fields(algo.config_class)}
            )
            raise ValueError(
                f"option {option} does not apply to --algo {args.algo}; it applies to: {takers}"
            )
        settings[dest] = tuple(value) if dest in LIST_FIELDS else value
    check_gym_id("--env", args.env)
    check_workers_option(args.workers, args.backend, args.ray_address)
    env_kwargs = unique_keys("--env-kwarg", args.env_kwarg)
    policy_params = unique_keys("--policy-param", args.policy_param)
    with options_named(CONFIG_OPTIONS):
        config = _config(algorithm, settings, args, env_kwargs, policy_params)
    return args.algo, config


# a config field -> the option that sets it, for errors that name what the user typed
CONFIG_OPTIONS = {
    **{dest: option for option, (dest, _, _) in ALGO_OPTIONS.items()},
    "env_id": "--env",
    "address": "--ray-address",
    **{
        name: "--" + name.replace("_", "-")
        for name in (
            "iterations",
            "demos_per_iteration",
            "samples_per_demo",
            "eval_episodes",
            "eval_every",
            "eval_at",
            "max_steps",
            "return_floor",
            "seed",
            "workers",
            "backend",
        )
    },
}


def _config(algorithm, settings, args, env_kwargs, policy_params) -> Any:
    from fluids_bench.algos.learners.protocol import NamedFactory
    from fluids_bench.algos.learners.sklearn import PolicySpec

    return algorithm.config_class(
        **settings,
        env_id=args.env,
        env_kwargs=env_kwargs,
        policy=(
            NamedFactory(args.policy, policy_params)
            if ":" in args.policy
            else PolicySpec(args.policy, policy_params)
        ),
        iterations=args.iterations,
        demos_per_iteration=args.demos_per_iteration,
        samples_per_demo=args.samples_per_demo,
        eval_episodes=args.eval_episodes,
        eval_every=args.eval_every,
        eval_at=None if args.eval_at is None else tuple(args.eval_at),
        max_steps=args.max_steps,
        return_floor=args.return_floor,
        seed=args.seed,
        workers=args.workers,
        backend=args.backend,
        address=args.ray_address,
    )


def _payload(name: str, config: Any, records: list[Any]) -> dict[str, Any]:
    """The JSON of a run stopped after `records` (`"complete": false`): the finished
    iterations' records and the config; the supervisor's reference return comes with the
    complete result only."""
    return {
        "algo": name,
        "config": config.to_dict(),
        "records": [dataclasses.asdict(r) for r in records],
        "complete": False,
    }


def _saved_run_is_complete(path: Path, name: str, config: Any) -> bool:
    """Whether `path` holds the complete result of this run; a run with other settings there
    is refused (`--resume` continues a run, it does not replace one)."""
    if not path.is_file():
        return False
    saved = json.loads(path.read_text())
    settings = json.loads(json.dumps(config.to_dict()))
    if saved.get("algo") != name or saved.get("config") != settings:
        old = saved.get("config", {})
        different = sorted(k for k in set(old) | set(settings) if old.get(k) != settings.get(k))
        raise ValueError(
            f"--resume: {path} holds a run with other settings ({', '.join(different) or 'algo'}"
            " differ); allowed: the command that wrote it, or another --out"
        )
    return bool(saved.get("complete"))


def _number(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.3f}"


def main(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from fluids_bench.algos.harness import make_env
    from fluids_bench.algos.plots import plot_learning_curves
    from fluids_bench.algos.registry import get_algorithm
    from fluids_bench.algos.results import write_json_atomic
    from fluids_bench.core.parallel import interrupted

    name, config = build_config(args)
    make_env(config.env_id, dict(config.env_kwargs)).close()  # fail before the progress bar
    if config.backend == "ray":
        from fluids_bench.core.parallel import import_ray

        try:
            import_ray()
        except ImportError as exc:  # the ray extra is missing
            print(f"fluids-bench train: error: {exc}", file=sys.stderr)
            return 2
    stem = f"{name}_{config.env_id}_seed{config.seed}"
    json_path, png_path = args.out / f"{stem}.json", args.out / f"{stem}.png"
    checkpoint = args.out / f"{stem}.checkpoint"
    if args.resume:
        if _saved_run_is_complete(json_path, name, config):
            print(f"{json_path} holds this run, complete; nothing to resume")
            return 0
        from fluids_bench.algos.checkpoint import Checkpoint

        if checkpoint.is_dir():
            Checkpoint(checkpoint, name, config)  # refuses a folder of another run, now
            done = len(list(checkpoint.glob("record-*.pkl")))
            print(f"resuming: {done} finished iterations in {checkpoint}")
        else:
            print(f"resuming: nothing saved in {checkpoint}; starting from the beginning")
    elif checkpoint.exists():
        shutil.rmtree(checkpoint)  # a new run: what an earlier one left is not reused
    config = dataclasses.replace(config, checkpoint=str(checkpoint))
    # iteration 0 exists when the algorithm starts with initial demonstrations
    total = config.iterations + (1 if getattr(config, "initial_demos", 0) else 0)
    finished: list[Any] = []
    try:
        with tqdm(total=total, desc=f"{name} on {config.env_id}", disable=args.no_progress) as bar:

            def progress(record: Any) -> None:
                bar.update(1)
                if record.normalised_performance is not None:
                    bar.set_postfix(
                        perf=f"{record.normalised_performance:.3f}", labels=record.labels_requested
                    )
                # every finished iteration goes to disk at once (atomically), so that Ctrl-C or
                # a crash later in the run keeps it
                finished.append(record)
                write_json_atomic(json_path, _payload(name, config, finished))

            result = get_algorithm(name).run(config, progress)
    except (KeyboardInterrupt, SystemError) as exc:
        if not interrupted(exc):
            raise
        if finished:
            kept = (
                f"the {len(finished)} finished iterations are in {json_path} (complete: false); "
                "the same command with --resume continues the run"
            )
        else:
            kept = (
                "no iteration had finished; the same command with --resume continues from the "
                f"finished rollouts in {checkpoint}"
            )
        print(f"fluids-bench train: interrupted; {kept}", file=sys.stderr)
        return 130
    learner = getattr(result.policy, "learner", None)
    saved_learner = None
    if callable(getattr(learner, "save", None)):
        # the final learner, loadable with fluids_bench.algos.learners.load_learner
        saved_learner = learner.save(args.out / f"{stem}.learner.npz")
    write_json_atomic(json_path, {**result.to_dict(), "complete": True})
    plot_learning_curves([result], png_path, args.x_axis)
    shutil.rmtree(checkpoint, ignore_errors=True)  # the complete JSON is the result now
    final = result.final
    success = (
        ""
        if final.eval_success_rate is None
        else f"success {final.eval_success_rate:.2f} ± {final.eval_success_se or 0.0:.2f}, "
    )
    print(
        f"{name} on {config.env_id}: normalised performance "
        f"{_number(final.normalised_performance)}, "
        f"{success}{final.training_labels} training labels "
        f"(+{final.estimation_labels} for noise estimation), "
        f"{final.train_seconds:.3f} s fitting, {final.wall_seconds:.3f} s collecting, labelling "
        "and fitting in all (evaluation and start-up not counted)"
    )
    print(f"wrote {json_path} and {png_path}")
    if saved_learner is not None:
        print(f"wrote the final learner to {saved_learner} (load_learner reads it)")
    return 0
