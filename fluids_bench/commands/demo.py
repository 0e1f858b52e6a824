"""``fluids-bench demo``: one seeded FLUIDS-v0 episode under the supervisor, with a video.

The ego follows the supervisor's label (``info["supervisor_action"]``) every step. The command
prints a summary (success, collisions, steps, simulation speed) and writes an MP4 of the episode
and a PNG snapshot (the first collision if there is one, else the ego nearest the junction's
centre) under ``--out``. Steps per second time ``env.step`` alone: drawing and encoding frames
are not counted.

Example::

    fluids-bench demo --seed 3 --layout roundabout --steps 300 --out fluids_demo
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from fluids_bench.tasks.fluids.sim.config import LAYOUTS

VIDEO_NAME, SNAPSHOT_NAME = "episode.mp4", "episode.png"


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = subparsers.add_parser(
        "demo",
        help="run a seeded FLUIDS-v0 episode under the supervisor; write an MP4 and a PNG",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--seed", type=int, default=0, help="episode seed (default 0)")
    p.add_argument("--layout", choices=LAYOUTS, default="four_way", help="default four_way")
    p.add_argument("--steps", type=int, default=400, help="most steps to run (default 400)")
    p.add_argument("--out", type=Path, default=Path("fluids_demo"), help="output folder")
    p.add_argument(
        "--no-video", action="store_true", help="skip the MP4 (the PNG is still written)"
    )
    p.set_defaults(func=run)


def _write_png(path: Path, frame) -> None:
    import cv2

    if not cv2.imwrite(str(path), cv2.cvtColor(frame, cv2.COLOR_RGB2BGR)):
        raise FileNotFoundError(f"could not write {path}")


def _load_kernels(layout: str) -> None:
    """A few throwaway steps, so that loading the compiled kernels (compiling them, on a
    machine's first run: a few seconds) is not counted in the episode's steps per second."""
    import gymnasium as gym

    env = gym.make("FLUIDS-v0", layout=layout)
    _, info = env.reset(seed=0)
    for _ in range(10):
        _, _, terminated, truncated, info = env.step(info["supervisor_action"])
        if terminated or truncated:
            break
    env.close()


def run(args: argparse.Namespace) -> int:
    import gymnasium as gym
    import imageio.v2 as imageio
    import numpy as np

    import fluids_bench  # noqa: F401  (registers the env ids)

    if args.steps < 1:
        raise ValueError(f"--steps is {args.steps}; allowed: an integer >= 1")
    args.out.mkdir(parents=True, exist_ok=True)
    env = gym.make(
        "FLUIDS-v0", layout=args.layout, render_mode="rgb_array", max_episode_steps=args.steps
    )
    _load_kernels(args.layout)
    obs, info = env.reset(seed=args.seed)
    sim = env.unwrapped
    centre = np.mean(np.reshape(sim.world.layout.bounds, (2, 2)), axis=0)

    def ego_distance() -> float:
        return float(np.hypot(*(sim.world.state[0, :2] - centre)))

    writer = None
    if not args.no_video:
        writer = imageio.get_writer(
            args.out / VIDEO_NAME,
            fps=env.metadata["render_fps"],
            codec="libx264",
            quality=7,
            macro_block_size=16,
            pixelformat="yuv420p",
            ffmpeg_params=["-preset", "veryfast"],
        )
    best, snapshot = np.inf, None  # snapshot score: ego distance to centre; a collision wins

    def consider(score: float) -> None:
        nonlocal best, snapshot
        frame = None
        if writer is not None:
            frame = env.render()
            writer.append_data(frame)
        if score < best:
            best = score
            snapshot = frame if frame is not None else env.render()

    consider(ego_distance())
    steps, collisions, sim_seconds, success = 0, [], 0.0, False
    try:
        while True:
            t0 = time.perf_counter()
            obs, reward, terminated, truncated, info = env.step(info["supervisor_action"])
            sim_seconds += time.perf_counter() - t0
            steps += 1
            first_hit = bool(info["collisions"]) and not collisions
            collisions.extend(info["collisions"])
            consider(-1.0 if first_hit else ego_distance())
            if terminated or truncated:
                success = bool(info.get("is_success", False))
                break
    finally:
        if writer is not None:
            writer.close()
        env.close()
    _write_png(args.out / SNAPSHOT_NAME, snapshot)
    ego = sum(1 for c in collisions if 0 in (c["a"], c["b"]))
    print(f"FLUIDS-v0 demo: layout {args.layout}, seed {args.seed}, ego route {info['route']}")
    print(
        f"  success: {success}   steps: {steps}   collisions: {len(collisions)} ({ego} involving the ego)"
    )
    print(
        f"  simulation: {steps / max(sim_seconds, 1e-9):.0f} steps/s ({steps} steps in "
        f"{sim_seconds:.2f} s; drawing and video not counted)"
    )
    wrote = [str(args.out / SNAPSHOT_NAME)]
    if writer is not None:
        wrote.insert(0, f"{args.out / VIDEO_NAME} ({steps + 1} frames)")
    print("  wrote " + " and ".join(wrote))
    return 0
