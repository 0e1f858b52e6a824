"""`fluids-bench collect`: roll out an env's supervisor and write a Minari dataset.

Actions are the supervisor's labels; what was executed, and by whom, is in the infos (see
`fluids_bench.data.minari_export`). Episode `i` uses seed `--seed + i`, so the data do
not depend on `--workers` or `--backend`.

Everything that can refuse does so before collecting: an existing id (without
`--overwrite`), `--data-format hdf5` without h5py (the `hdf5` extra), and an id another
run is writing right now (`fluids_bench.core.parallel`). Reference scores: given
`--ref-min-score`/`--ref-max-score`, those; otherwise the id's measured ones where the
project has them (the mean return of random actions and of the default supervisor, today the
locomotion ids with their default supervisor), else none.

Nothing finished is lost when a run stops: each episode is written to disk as it finishes
(`fluids_bench.data.partial`). After Ctrl-C or SIGTERM the finished episodes are exported
as the dataset, marked incomplete (its description starts with `INCOMPLETE` and
`fluids_bench_incomplete.json` lists them), and the command exits with 130; after SIGKILL they
stay on disk. Either way `--resume` with the same arguments collects the missing episodes and
writes the complete dataset, identical to an uninterrupted run's. Example:

    fluids-bench collect --env FLUIDS-v0 --episodes 100 --dataset fluids/velocity-noisy-v0 \\
        --env-kwarg action_level=velocity --noise 0.5 --workers 2
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import signal
import sys
import threading
from pathlib import Path
from typing import Any

from fluids_bench.commands import plain_text
from fluids_bench.commands.arguments import key_value

INCOMPLETE_FILE = "fluids_bench_incomplete.json"  # in a dataset an interrupted run exported


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "collect",
        help="collect supervisor-labelled episodes into a Minari dataset",
        description=plain_text(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--env", required=True, help="registered env id, e.g. FLUIDS-v0")
    parser.add_argument("--episodes", required=True, type=int)
    parser.add_argument(
        "--dataset",
        required=True,
        metavar="NAMESPACE/NAME-vK",
        help="Minari dataset id (under MINARI_DATASETS_PATH)",
    )
    parser.add_argument(
        "--env-kwarg",
        action="append",
        type=key_value,
        default=[],
        metavar="K=V",
        help="env keyword argument (V parsed as JSON when it is)",
    )
    parser.add_argument(
        "--noise",
        type=float,
        default=None,
        metavar="LEVEL",
        help="inject noise: Gaussian std for Box actions, probability of "
        "another action for Discrete ones (labels stay the supervisor's)",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of episode 0 (default 0)")
    parser.add_argument(
        "--max-steps",
        type=int,
        default=None,
        help="cut episodes after this many steps (default: the env's limit)",
    )
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--backend", choices=["process", "ray"], default="process")
    parser.add_argument(
        "--ray-address", default=None, help="Ray cluster address (default: start a local Ray)"
    )
    parser.add_argument("--overwrite", action="store_true", help="replace an existing dataset")
    parser.add_argument(
        "--resume",
        action="store_true",
        help="finish an interrupted collection into --dataset (same arguments)",
    )
    parser.add_argument("--data-format", choices=["arrow", "hdf5"], default="arrow")
    parser.add_argument("--author", default="fluids-bench")
    parser.add_argument("--author-email", default=None)
    parser.add_argument("--code-permalink", default=None)
    parser.add_argument("--description", default=None)
    parser.add_argument(
        "--ref-min-score",
        type=float,
        default=None,
        help="reference score of a random policy (give both or neither; default: the id's "
        "measured one, where there is one)",
    )
    parser.add_argument(
        "--ref-max-score",
        type=float,
        default=None,
        help="reference score of an expert (give both or neither; default: the id's "
        "measured one, where there is one)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.set_defaults(func=run)


def reference_scores(env) -> tuple[float | None, float | None]:
    """`(ref_min_score, ref_max_score)` where the project has measured them for this env
    (`metadata["reference_scores"]`: the mean return of random actions and of the id's
    default supervisor; today the locomotion ids), else `(None, None)`: both or neither,
    since Minari given only one would run 100 random episodes to estimate the other."""
    refs = env.unwrapped.metadata.get("reference_scores") or {}
    low, high = refs.get("random"), refs.get("supervisor")
    if low is None or high is None:
        return None, None
    return float(low), float(high)


def run(args: argparse.Namespace) -> int:
    previous = signal.getsignal(signal.SIGTERM)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _terminated)  # SIGTERM keeps finished work, as Ctrl-C
    try:
        return _run(args)
    except ImportError as exc:  # an extra is missing (ray, hdf5)
        print(f"fluids-bench collect: error: {exc}", file=sys.stderr)
        return 2
    finally:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, previous)


def _terminated(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt(f"signal {signum}")


def run_record(args: argparse.Namespace, env_kwargs: dict, actor) -> dict[str, Any]:
    """What the data depend on: a resumed run must have the same (the `run.json` of
    `fluids_bench.data.partial`)."""
    return {
        "env": args.env,
        "env_kwarg": env_kwargs,
        "episodes": args.episodes,
        "seed": args.seed,
        "max_steps": args.max_steps,
        "noise": args.noise,
        "actor": actor.describe(),
        "data_format": args.data_format,
    }


def _run(args: argparse.Namespace) -> int:
    import gymnasium as gym

    from fluids_bench.commands.options import (
        check_finite_option,
        check_gym_id,
        check_int_option,
        check_supervised,
        check_workers_option,
        options_named,
        unique_keys,
    )
    from fluids_bench.core.parallel import claim_dataset
    from fluids_bench.data.collect import ActorSpec
    from fluids_bench.data.minari_export import check_data_format, datasets_root
    from fluids_bench.data.partial import PartialCollection

    if args.resume and args.overwrite:
        raise ValueError("--resume and --overwrite were both given; allowed: one of them")
    # everything that can refuse does so before collecting, not after
    check_target(args)
    check_data_format(args.data_format)
    # episode i is seeded --seed + i, and a seed has 32 bits
    check_int_option("--episodes", args.episodes, 1, max(1, 2**32 - args.seed))
    check_workers_option(args.workers, args.backend, args.ray_address)
    if args.max_steps is not None:
        check_int_option("--max-steps", args.max_steps, 1)
    check_finite_option("--ref-min-score", args.ref_min_score)
    check_finite_option("--ref-max-score", args.ref_max_score)
    if (args.ref_min_score is None) != (args.ref_max_score is None):
        raise ValueError(
            f"--ref-min-score is {args.ref_min_score} and --ref-max-score is "
            f"{args.ref_max_score}; allowed: both given, or neither"
        )
    if args.ref_min_score is not None and not args.ref_min_score < args.ref_max_score:
        raise ValueError(
            f"--ref-min-score is {args.ref_min_score} and --ref-max-score is "
            f"{args.ref_max_score}; allowed: a minimum below the maximum (Minari normalises "
            "returns by their difference)"
        )
    env_kwargs = unique_keys("--env-kwarg", args.env_kwarg)
    check_gym_id("--env", args.env)
    probe = gym.make(args.env, **env_kwargs)
    try:
        check_supervised("--env", args.env, probe)
        discrete = isinstance(probe.action_space, gym.spaces.Discrete)
        if args.ref_min_score is None:
            args.ref_min_score, args.ref_max_score = reference_scores(probe)
    finally:
        probe.close()
    with options_named({"epsilon": "--noise", "noise_std": "--noise"}):
        if args.noise is None:
            actor = ActorSpec()
        elif discrete:
            actor = ActorSpec("noise", epsilon=args.noise)
        else:
            actor = ActorSpec("noise", noise_std=args.noise)
    record = run_record(args, env_kwargs, actor)
    root = datasets_root()
    # one writer per id: a concurrent collect into the same id is refused here, up front
    with claim_dataset(root, args.dataset):
        check_target(args)  # a run that finished meanwhile
        partial = PartialCollection(root, args.dataset)
        if args.resume:
            if not partial.exists():
                raise FileNotFoundError(
                    f"--resume: no interrupted collection of {args.dataset!r} to finish "
                    f"(nothing under {partial.folder}); run without --resume to collect it"
                )
            partial.check_same(record)
        elif partial.exists() and not args.overwrite:
            raise FileExistsError(
                f"an interrupted collection of {args.dataset!r} has "
                f"{len(partial.done())} of {partial.run()['episodes']} episodes at "
                f"{partial.folder}; pass --resume to finish it, or --overwrite to start again"
            )
        else:
            partial.start(record)
        return _collect_and_export(args, env_kwargs, actor, partial)


def check_target(args: argparse.Namespace) -> None:
    """Refuse a dataset id that exists, unless `--overwrite`, or `--resume` of a dataset an
    interrupted run left incomplete."""
    from fluids_bench.data.minari_export import check_new_dataset, dataset_path

    incomplete = incomplete_record(dataset_path(args.dataset))
    if incomplete is not None and not (args.resume or args.overwrite):
        raise FileExistsError(
            f"dataset {args.dataset!r} is incomplete ({len(incomplete['episodes'])} of "
            f"{incomplete['of']} episodes, an interrupted collect); pass --resume to finish it, "
            "or --overwrite to replace it"
        )
    check_new_dataset(args.dataset, args.overwrite or (args.resume and incomplete is not None))


def incomplete_record(folder: Path) -> dict[str, Any] | None:
    """The `fluids_bench_incomplete.json` of the dataset at `folder`, or None when the
    dataset is complete or absent."""
    try:
        return json.loads((folder / INCOMPLETE_FILE).read_text())
    except FileNotFoundError:
        return None


def _collect_and_export(args: argparse.Namespace, env_kwargs: dict, actor, partial) -> int:
    from fluids_bench.core.parallel import interrupted
    from fluids_bench.data.collect import collect
    from fluids_bench.data.minari_export import dataset_path, env_spaces, episode_buffer

    _, observation_space, action_space = env_spaces(args.env, env_kwargs)

    def save(index: int, trajectory) -> None:
        buffer = episode_buffer(index, trajectory, actor.kind, observation_space, action_space)
        partial.save(index, buffer)

    try:
        collect(
            args.env,
            args.episodes,
            env_kwargs=env_kwargs,
            actor=actor,
            seed=args.seed,
            max_steps=args.max_steps,
            workers=args.workers,
            backend=args.backend,
            address=args.ray_address,
            progress=not args.no_progress,
            skip=partial.done(),
            on_episode=save,
        )
    except BaseException as exc:
        if interrupted(exc) and partial.done():
            kept = _export(args, env_kwargs, actor, partial, complete=False)
            print(
                f"fluids-bench collect: kept {kept} finished episodes of {args.episodes} in "
                f"{dataset_path(args.dataset)} (marked incomplete); the same command with "
                "--resume finishes it",
                file=sys.stderr,
            )
        raise
    _export(args, env_kwargs, actor, partial, complete=True)
    partial.remove()
    return 0


def _export(args: argparse.Namespace, env_kwargs: dict, actor, partial, complete: bool) -> int:
    """Export the episodes on disk (all of them when `complete`); returns how many."""
    from fluids_bench.data.minari_export import dataset_path, export_buffers

    indices = partial.done()
    buffers = [partial.load(i) for i in indices]
    seeds = f"seeds {args.seed}..{args.seed + args.episodes - 1}"
    description = args.description or (
        f"{args.episodes} episodes of {args.env} ({seeds}) "
        f"acted by the {actor.describe()}; actions are the supervisor's labels, "
        "infos['executed_action'][t + 1] is the action executed at step t and "
        "infos['provenance'][t + 1] who chose it."
    )
    add_files = None
    if not complete:
        buffers = [dataclasses.replace(b, id=k) for k, b in enumerate(buffers)]
        description = (
            f"INCOMPLETE: {len(indices)} of {args.episodes} episodes (interrupted; each "
            f"episode's seed is in its metadata; 'fluids-bench collect ... --resume' finishes "
            f"it). {description}"
        )
        marker = {"episodes": indices, "of": args.episodes, "seed": args.seed}

        def add_files(folder: Path) -> None:
            (folder / INCOMPLETE_FILE).write_text(json.dumps(marker))

    replace = args.overwrite or incomplete_record(dataset_path(args.dataset)) is not None
    dataset = export_buffers(
        args.dataset,
        buffers,
        env_id=args.env,
        env_kwargs=env_kwargs,
        algorithm_name=f"fluids-bench collect: {actor.describe()}",
        description=description,
        author=args.author,
        author_email=args.author_email,
        code_permalink=args.code_permalink,
        ref_min_score=args.ref_min_score,
        ref_max_score=args.ref_max_score,
        overwrite=replace,
        data_format=args.data_format,
        add_files=add_files,
    )
    if complete:
        json.dump(
            {
                "dataset": args.dataset,
                "path": str(dataset.spec.data_path),
                "episodes": dataset.total_episodes,
                "steps": dataset.total_steps,
                "provenance": actor.kind,
            },
            sys.stdout,
        )
        print()
    return len(indices)
