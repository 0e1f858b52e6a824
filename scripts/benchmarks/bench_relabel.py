"""Labels per minute of the relabelling tool in scripted sessions (the tool's own ceiling).

For each task: a simulated person teleoperates one episode (states stored every
``--snapshot-every`` steps), then a relabelling session in a real pygame window (SDL's dummy
driver, or the X display when one is set) is driven by posted events: one confirming input
(the task's key, or a click) as soon as each state is shown. What is measured is everything
but the person: rebuilding each state (restore and replay), drawing it, the window loop. A
person's rate is bounded by this and, in practice, set by the person.

    python scripts/benchmarks/bench_relabel.py --results docs/results/relabel_rate.json
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time

TASKS = [
    # (env id, env kwargs, the confirming event)
    ("GridWorld-v0", {}, ("key", "K_SPACE")),
    ("DrivingTrack-v0", {}, ("key", "K_UP")),
    ("Singulation-v0", {}, ("click", (200, 150))),
    ("GraspingInClutter-v0", {}, ("click", (240, 150))),
    ("FLUIDS-v1", {"num_pedestrians": 0, "num_cars": 3}, ("key", "K_RETURN")),
]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=60, help="states labelled per task")
    parser.add_argument("--snapshot-every", type=int, default=10)
    parser.add_argument("--tasks", nargs="*", default=None, help="env ids (default: all five)")
    parser.add_argument("--results", default=None)
    args = parser.parse_args(argv)
    print("expected run time: ~1 min on 2 cores")
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy" if "DISPLAY" not in os.environ else "x11")
    os.environ["FLUIDS_BENCH_HEADLESS"] = "1"  # a script, not a person, drives the window
    os.environ["MINARI_DATASETS_PATH"] = tempfile.mkdtemp(prefix="bench-relabel-")

    import minari
    import pygame

    from fluids_bench.algos.results import write_json_atomic
    from fluids_bench.human.recording import env_spec, load_episodes, spec_of, write_dataset
    from fluids_bench.human.session import Relabel, Teleop
    from fluids_bench.human.simulated import SimulatedHuman

    rows = []
    for env_id, kwargs, (kind, what) in TASKS:
        if args.tasks and env_id not in args.tasks:
            continue
        teleop = Teleop(
            env_id,
            kwargs,
            max_steps=args.steps,
            snapshot_every=args.snapshot_every,
            human=SimulatedHuman(),
        )
        spec = env_spec(teleop.env)
        result = teleop.run()
        dataset_id = f"bench/{env_id.lower()}-v0"
        write_dataset(
            dataset_id,
            result.episodes,
            spec,
            session={"kind": "teleop"},
            algorithm_name="bench",
            description="bench_relabel.py",
        )
        data = minari.load_dataset(dataset_id)

        def script(s, kind=kind, what=what):
            if getattr(s, "_posted", None) != s.index:
                s._posted = s.index
                if kind == "key":
                    pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=getattr(pygame, what)))
                else:
                    pygame.event.post(
                        pygame.event.Event(pygame.MOUSEBUTTONDOWN, button=1, pos=what)
                    )

        session = Relabel(spec_of(data), load_episodes(data), dataset_id, script=script)
        started = time.perf_counter()
        out = session.run()
        seconds = time.perf_counter() - started
        row = {
            "env_id": env_id,
            "env_kwargs": kwargs,
            "labels": len(out.labels),
            "seconds": round(seconds, 3),
            "labels_per_minute": round(60 * len(out.labels) / seconds, 1),
        }
        print(row)
        rows.append(row)
    if args.results:
        write_json_atomic(
            args.results,
            {
                "command": "python " + " ".join([sys.argv[0], *(argv or sys.argv[1:])]),
                "settings": {
                    "steps": args.steps,
                    "snapshot_every": args.snapshot_every,
                    "video_driver": os.environ["SDL_VIDEODRIVER"],
                },
                "seeds": {"teleop": 0},
                "machine": f"{platform.machine()}, {os.cpu_count()} cores (shared)",
                "tasks": rows,
            },
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
