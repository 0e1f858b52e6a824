"""`fluids-bench teleop`: drive an env yourself in a window and record a Minari dataset.

The window (pygame, the `human` extra) shows the env and reads the task's controls: FLUIDS
(arrow keys or a gamepad; at `action_level=velocity` the target speed), DrivingTrack (left /
straight / right), Singulation and GraspingInClutter (mouse), GridWorld (arrow keys). `p`
pauses, `s` slows down, `r` restarts the episode, `l` shows the supervisor's label,
Esc / `q` / closing the window ends the session. The dataset's `actions` are your actions,
next to the supervisor's labels, time stamps, reaction times, seeds, the env spec and the env
states (see `fluids_bench.human.recording`). Finished episodes are written atomically when
the session ends (also after Ctrl-C); an unfinished episode is dropped. Example:

    fluids-bench teleop --env GridWorld-v0 --episodes 3 --dataset teleop/grid-v0
    fluids-bench teleop --env Singulation-v0 --dataset teleop/sing-v0 --noise dart
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys

from fluids_bench.commands import plain_text
from fluids_bench.commands.arguments import key_value


def _noise(text: str) -> float | str:
    if text == "dart":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number or 'dart', got {text!r}") from None


def add_human_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--simulated-human",
        nargs="?",
        const="",
        default=None,
        metavar="SETTINGS",
        help="a simulated person instead of you, no window: the supervisor delayed and noisy "
        "('delay=2,noise_std=0.1,epsilon=0.05', the defaults)",
    )
    parser.add_argument(
        "--show-label", action="store_true", help="overlay the supervisor's label (key l)"
    )
    parser.add_argument(
        "--trust-pickle",
        action="store_true",
        help="read env states an older fluids-bench stored as pickles (a pickle can run any "
        "code its maker put in it: only for datasets you trust); they are rewritten safely",
    )


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "teleop",
        help="teleoperate an env in a window; record a Minari dataset",
        description=plain_text(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--env", required=True, help="env id, e.g. GridWorld-v0, FLUIDS-v1")
    parser.add_argument("--env-kwarg", action="append", type=key_value, default=[], metavar="K=V")
    parser.add_argument("--dataset", required=True, metavar="NAMESPACE/NAME-vK")
    parser.add_argument("--episodes", type=int, default=1, help="episodes to record (default 1)")
    parser.add_argument(
        "--seed",
        type=int,
        default=None,
        help="seed of the first episode (default 0, or after "
        "the dataset's last seed with --append)",
    )
    parser.add_argument("--max-steps", type=int, default=None, help="end episodes after N steps")
    parser.add_argument("--fps", type=float, default=None, help="steps per second (per task)")
    parser.add_argument(
        "--snapshot-every",
        type=int,
        default=10,
        metavar="N",
        help="store the env state every N steps (the others are rebuilt by replaying; "
        "default 10: a FLUIDS state is ~0.2 MB, a DrivingTrack one ~0.8 MB)",
    )
    parser.add_argument(
        "--noise",
        type=_noise,
        default=None,
        metavar="LEVEL|dart",
        help="human DART: add noise to the executed action (std for Box actions, chance of "
        "another action for Discrete ones, or 'dart' to estimate it after each episode); "
        "your intended action is recorded",
    )
    parser.add_argument(
        "--dart-alpha", type=float, default=None, help="--noise dart: target trace of Sigma"
    )
    parser.add_argument("--append", action="store_true", help="add episodes to an existing id")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing dataset")
    add_human_options(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import minari

    from fluids_bench.core.validation import check_int
    from fluids_bench.human.recording import check_writable, env_spec
    from fluids_bench.human.session import Teleop
    from fluids_bench.human.simulated import person

    check_int("teleop", "--episodes", args.episodes, 1)
    check_int("teleop", "--snapshot-every", args.snapshot_every, 1)
    if args.max_steps is not None:
        check_int("teleop", "--max-steps", args.max_steps, 1)
    exists = check_writable(args.dataset, overwrite=args.overwrite, append=args.append)
    seed = args.seed
    if seed is None:
        seed = 0
        if args.append and exists:
            dataset = minari.load_dataset(args.dataset)
            seeds = [
                m.get("seed") for m in dataset.storage.get_episode_metadata(dataset.episode_indices)
            ]
            seed = 1 + max((s for s in seeds if s is not None), default=-1)
    # a simulated one, or pygame and a real display for a real one
    human = person(args.simulated_human, "fluids-bench teleop")
    session = Teleop(
        args.env,
        dict(args.env_kwarg),
        episodes=args.episodes,
        seed=seed,
        max_steps=args.max_steps,
        fps=args.fps,
        snapshot_every=args.snapshot_every,
        show_label=args.show_label,
        noise=args.noise,
        dart_alpha=args.dart_alpha,
        human=human,
    )
    spec = env_spec(session.env)
    result = session.run()
    return finish(args, session, result, spec)


def finish(args, session, result, spec) -> int:
    from fluids_bench.human.recording import write_dataset

    code = 130 if result.ended == "interrupted" else 0
    who = "you" if session.human is None else session.human.describe()
    summary = {
        "dataset": args.dataset,
        "episodes": len(result.episodes),
        "steps": sum(len(e) for e in result.episodes),
        "ended": result.ended,
        "seconds": round(result.seconds, 3),
    }
    if not result.episodes:
        print(
            f"fluids-bench teleop: no finished episode (session {result.ended}); nothing written",
            file=sys.stderr,
        )
        return code or 1
    window = session.window
    if session.human is None and (window is None or window.events == 0):
        print(
            "fluids-bench teleop: the session received no input (no key press, click or "
            "joystick event), so it is not a person's demonstration; nothing written",
            file=sys.stderr,
        )
        return code or 1
    noise = "" if not session.noise.active else f", noise {args.noise}"
    record = {
        "kind": "teleop",
        "who": who,
        "env": spec.id,
        "seeds": [e.seed for e in result.episodes],
        "noise": args.noise,
        "snapshot_every": args.snapshot_every,
        "fps": session.fps,
        "ended": result.ended,
        "seconds": result.seconds,
        "finished_at": datetime.datetime.now(datetime.UTC).isoformat(),
    }
    dataset = write_dataset(
        args.dataset,
        result.episodes,
        spec,
        session=record,
        append=args.append,
        overwrite=args.overwrite,
        trust_pickle=args.trust_pickle,
        algorithm_name=f"fluids-bench teleop: {who}{noise}",
        description=(
            f"Teleoperated episodes of {spec.id} ({who}{noise}). actions are the person's "
            "intended actions; infos hold executed_action, supervisor_action, time, "
            "reaction_time, noise_level, provenance (row t + 1 for step t) and state_stored; "
            "env states in fluids_bench_states/."
        ),
    )
    summary["total_episodes"] = dataset.total_episodes
    json.dump(summary, sys.stdout)
    print()
    return code
