"""Screenshots of the teleop and relabel windows for docs/humans.md (run it under Xvfb).

Each window is driven by posted pygame events (as the tests do) and saved mid-session:

    xvfb-run -a python scripts/figures/human_screenshots.py --out docs/images
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

TELEOP = [
    # (name, env id, kwargs, steps before the shot, events posted at each step)
    ("fluids", "FLUIDS-v1", {}, 12, ("key", "K_UP")),
    ("singulation", "Singulation-v0", {}, 30, ("drag", (150, 170))),
    ("grasping", "GraspingInClutter-v0", {}, 20, ("drag", (240, 200))),
    ("gridworld", "GridWorld-v0", {}, 4, ("key", "K_UP")),
    ("track", "DrivingTrack-v0", {}, 8, ("key", "K_LEFT")),
]
RELABEL = [("singulation", "Singulation-v0", {}, 12), ("fluids", "FLUIDS-v1", {}, 20)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/images"))
    args = parser.parse_args(argv)
    print("expected run time: ~1 min on 2 cores")
    os.environ["FLUIDS_BENCH_HEADLESS"] = "1"  # a script, not a person, drives the windows
    os.environ["MINARI_DATASETS_PATH"] = tempfile.mkdtemp(prefix="screenshots-")
    args.out.mkdir(parents=True, exist_ok=True)

    import minari
    import pygame

    from fluids_bench.human.recording import env_spec, load_episodes, spec_of, write_dataset
    from fluids_bench.human.session import Relabel, Teleop
    from fluids_bench.human.simulated import SimulatedHuman

    for name, env_id, kwargs, at, (kind, what) in TELEOP:

        def script(s, at=at, kind=kind, what=what, name=name):
            if s.current is None or s.window is None:
                return
            t = len(s.current.actions)
            if getattr(s, "_t", None) == t:
                return
            s._t = t
            if kind == "key":
                pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=getattr(pygame, what)))
            elif t == 0:
                pygame.event.post(pygame.event.Event(pygame.MOUSEBUTTONDOWN, button=1, pos=what))
            if t == at:
                s.window.save(args.out / f"teleop_{name}.png")
                s.stop = True

        Teleop(env_id, kwargs, fps=1000, show_label=True, script=script).run()
        if not (args.out / f"teleop_{name}.png").exists():
            raise RuntimeError(f"{env_id}: the episode ended before step {at}")
        print("wrote", args.out / f"teleop_{name}.png")

    for name, env_id, kwargs, at in RELABEL:
        teleop = Teleop(env_id, kwargs, max_steps=at + 1, human=SimulatedHuman(), snapshot_every=5)
        spec = env_spec(teleop.env)
        result = teleop.run()
        dataset_id = f"shots/{name}-v0"
        write_dataset(
            dataset_id,
            result.episodes,
            spec,
            session={"kind": "teleop"},
            algorithm_name="screenshots",
            description="human_screenshots.py",
        )
        data = minari.load_dataset(dataset_id)

        def script(s, at=at, name=name):
            if s.index == at and s.window is not None and s.window.screen is not None:
                s.window.save(args.out / f"relabel_{name}.png")
                s.stop = True
            elif getattr(s, "_i", None) != s.index:
                s._i = s.index
                pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_RETURN))

        Relabel(
            spec_of(data), load_episodes(data), dataset_id, show_label=True, script=script
        ).run()
        print("wrote", args.out / f"relabel_{name}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
