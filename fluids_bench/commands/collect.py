"""`fluids-bench collect`: roll out an env's supervisor and write a Minari dataset.

Actions are the supervisor's labels; what was executed, and by whom, is in the infos (see
`fluids_bench.data.minari_export`). Episode `i` uses seed `--seed + i`, so the data do
not depend on `--workers` or `--backend`.

Everything that can refuse does so before collecting: an existing id (without
`--overwrite`), `--data-format hdf5` without h5py (the `hdf5` extra), and an id another
run is writing right now (`fluids_bench.data.claims`). Reference scores: given
`--ref-min-score`/`--ref-max-score`, those; otherwise the id's measured ones where the
project has them (the mean return of random actions and of the default supervisor, today the
locomotion ids with their default supervisor), else none. Example:

    fluids-bench collect --env FLUIDS-v0 --episodes 100 --dataset fluids/velocity-noisy-v0 \\
        --env-kwarg action_level=velocity --noise 0.5 --workers 2
"""

from __future__ import annotations

import argparse
import json
import sys

from fluids_bench.commands import plain_text
from fluids_bench.commands.train import _key_value


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
        type=_key_value,
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
    try:
        return _run(args)
    except ImportError as exc:  # an extra is missing (ray, hdf5)
        print(f"fluids-bench collect: error: {exc}", file=sys.stderr)
        return 2


def _run(args: argparse.Namespace) -> int:
    import gymnasium as gym

    from fluids_bench.data.claims import claim_dataset
    from fluids_bench.data.collect import ActorSpec
    from fluids_bench.data.minari_export import check_data_format, check_new_dataset, datasets_root

    # everything that can refuse does so before collecting, not after
    check_new_dataset(args.dataset, args.overwrite)
    check_data_format(args.data_format)
    if (args.ref_min_score is None) != (args.ref_max_score is None):
        raise ValueError(
            f"--ref-min-score is {args.ref_min_score} and --ref-max-score is "
            f"{args.ref_max_score}; allowed: both given, or neither"
        )
    env_kwargs = dict(args.env_kwarg)
    probe = gym.make(args.env, **env_kwargs)
    discrete = isinstance(probe.action_space, gym.spaces.Discrete)
    if args.ref_min_score is None:
        args.ref_min_score, args.ref_max_score = reference_scores(probe)
    probe.close()
    if args.noise is None:
        actor = ActorSpec()
    elif discrete:
        actor = ActorSpec("noise", epsilon=args.noise)
    else:
        actor = ActorSpec("noise", noise_std=args.noise)
    # one writer per id: a concurrent collect into the same id is refused here, up front
    with claim_dataset(datasets_root(), args.dataset):
        check_new_dataset(args.dataset, args.overwrite)  # a run that finished meanwhile
        return _collect_and_export(args, env_kwargs, actor)


def _collect_and_export(args: argparse.Namespace, env_kwargs: dict, actor) -> int:
    from fluids_bench.data.collect import collect
    from fluids_bench.data.minari_export import export_minari

    trajectories = collect(
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
    )
    description = args.description or (
        f"{args.episodes} episodes of {args.env} (seeds {args.seed}..{args.seed + args.episodes - 1}) "
        f"acted by the {actor.describe()}; actions are the supervisor's labels, "
        "infos['executed_action'][t + 1] is the action executed at step t and "
        "infos['provenance'][t + 1] who chose it."
    )
    dataset = export_minari(
        args.dataset,
        trajectories,
        env_id=args.env,
        env_kwargs=env_kwargs,
        provenance=actor.kind,
        algorithm_name=f"fluids-bench collect: {actor.describe()}",
        description=description,
        author=args.author,
        author_email=args.author_email,
        code_permalink=args.code_permalink,
        ref_min_score=args.ref_min_score,
        ref_max_score=args.ref_max_score,
        overwrite=args.overwrite,
        data_format=args.data_format,
    )
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
    return 0
