"""`fluids-bench relabel DATASET`: label a dataset's states after the fact (retroactively).

Each state of the dataset's episodes is rebuilt from the env states stored with it (or
replayed from the episode's seed when none are stored, e.g. a `collect` dataset), shown in a
window, and labelled with the task's teleop controls: a control key or a click labels it and
moves on, Return labels it with the input held, Backspace goes back, Esc ends the session.
The labels are written as a new dataset version (`NAME-vK` -> `NAME-v(K+1)`, or
`--out`): `actions` are the new labels, `infos["original_action"]` the old ones,
`infos["relabelled"]` says which steps were labelled and `infos["label_time"]` how long each
took; the rest is copied. The summary reports labels per minute. Example:

    fluids-bench relabel learner/grid-v0
    fluids-bench relabel learner/grid-v0 --simulated-human epsilon=0.1 --out learner/grid-v2
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys

from fluids_bench.commands import plain_text
from fluids_bench.commands.teleop import add_human_options


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "relabel",
        help="label a dataset's states retroactively; write a new dataset version",
        description=plain_text(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("dataset", metavar="DATASET", help="Minari dataset id to relabel")
    parser.add_argument("--out", default=None, help="output id (default: the next version)")
    parser.add_argument(
        "--episode", type=int, action="append", default=None, help="only these episodes (list)"
    )
    parser.add_argument("--every", type=int, default=1, help="label every k-th step (default 1)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the simulated human's noise")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    add_human_options(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import minari

    from fluids_bench.core.validation import check_int
    from fluids_bench.human.recording import check_writable, load_episodes, next_version, spec_of
    from fluids_bench.human.session import Relabel
    from fluids_bench.human.simulated import person

    check_int("relabel", "--every", args.every, 1)
    out = args.out or next_version(args.dataset)
    check_writable(out, overwrite=args.overwrite)
    try:
        dataset = minari.load_dataset(args.dataset)
    except (FileNotFoundError, ValueError) as exc:
        raise ValueError(f"cannot load dataset {args.dataset!r}: {exc}") from exc
    spec = spec_of(dataset)
    episodes = load_episodes(dataset, trust_pickle=args.trust_pickle)
    chosen = args.episode if args.episode is not None else range(len(episodes))
    for e in chosen:
        if not 0 <= e < len(episodes):
            raise ValueError(f"--episode {e}; allowed: 0..{len(episodes) - 1}")
    items = [(e, t) for e in chosen for t in range(0, len(episodes[e]), args.every)]
    # a simulated one, or pygame and a real display for a real one
    human = person(args.simulated_human, "fluids-bench relabel")
    session = Relabel(
        spec,
        episodes,
        args.dataset,
        items=items,
        human=human,
        seed=args.seed,
        show_label=args.show_label,
    )
    result = session.run()
    return finish(args, out, session, result, spec, episodes)


def finish(args, out, session, result, spec, episodes) -> int:
    import numpy as np

    from fluids_bench.human.recording import sessions, write_dataset
    from fluids_bench.human.relabelling import relabelled_episodes

    code = 130 if result.ended == "interrupted" else 0
    if not result.labels:
        print(
            f"fluids-bench relabel: no label given (session {result.ended}); nothing written",
            file=sys.stderr,
        )
        return code or 1
    who = "a person" if session.human is None else session.human.describe()
    changed = sum(
        not np.array_equal(np.asarray(label), np.asarray(episodes[e].actions[t]))
        for (e, t), (label, _) in result.labels.items()
    )
    summary = {
        "source": args.dataset,
        "dataset": out,
        "labels": len(result.labels),
        "of": len(session.items),
        "changed": int(changed),
        "ended": result.ended,
        "seconds": round(result.seconds, 3),
        "labels_per_minute": round(result.labels_per_minute, 1),
    }
    record = {
        "kind": "relabel",
        "who": who,
        "source": args.dataset,
        **{k: summary[k] for k in ("labels", "of", "changed", "ended", "labels_per_minute")},
        "seconds": result.seconds,
        "finished_at": datetime.datetime.now(datetime.UTC).isoformat(),
    }
    new = relabelled_episodes(episodes, result.labels, session.space)
    write_dataset(
        out,
        new,
        spec,
        session=record,
        overwrite=args.overwrite,
        previous_sessions=sessions(args.dataset),
        algorithm_name=f"fluids-bench relabel: {who}",
        description=(
            f"{args.dataset} relabelled retroactively by {who}: actions are the new labels "
            "where infos['relabelled'] is true (the original elsewhere); "
            "infos['original_action'] holds the source's actions, infos['label_time'] the "
            "seconds each label took (row t + 1 for step t)."
        ),
    )
    json.dump(summary, sys.stdout)
    print()
    return code
