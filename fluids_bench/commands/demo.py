"""``fluids-bench demo``: one seeded episode of any registered env under its supervisor, with a
video.

The controlled agent follows the supervisor's label (``info["supervisor_action"]``) every step;
frames come from ``render_mode="rgb_array"``. The command prints a summary and writes an MP4 of
the episode and a PNG snapshot under ``--out``. Steps per second time ``env.step`` alone: drawing
and encoding frames are not counted, and the env's compiled kernels (if any) are loaded in a
throwaway env first.

FLUIDS ids (the default, FLUIDS-v0) take ``--layout``; their summary gives success, collisions,
steps and simulation speed, and the snapshot is the first collision if there is one, else the
ego nearest the junction's centre. Other ids print success (when the env reports
``is_success``), return, steps and speed, and snapshot the last frame.

Examples::

    fluids-bench demo --seed 3 --layout roundabout --steps 300 --out fluids_demo
    fluids-bench demo --env GridWorld-v0 --out gridworld_demo
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from fluids_bench.tasks.fluids.sim.config import LAYOUTS

VIDEO_NAME, SNAPSHOT_NAME = "episode.mp4", "episode.png"
DEFAULT_ENV = "FLUIDS-v0"
FLUIDS_ENTRY_POINT = "fluids_bench.tasks.fluids.env:FluidsEnv"


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = subparsers.add_parser(
        "demo",
        help="run a seeded episode under the supervisor (default FLUIDS-v0); write an MP4 and a PNG",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--env", default=DEFAULT_ENV, help=f"registered env id (default {DEFAULT_ENV})")
    p.add_argument("--seed", type=int, default=0, help="episode seed (default 0)")
    p.add_argument(
        "--layout", choices=LAYOUTS, default=None, help="FLUIDS ids only (default four_way)"
    )
    p.add_argument(
        "--steps", type=int, default=None, help="most steps to run (default: the id's limit)"
    )
    p.add_argument("--out", type=Path, default=Path("fluids_demo"), help="output folder")
    p.add_argument(
        "--no-video", action="store_true", help="skip the MP4 (the PNG is still written)"
    )
    p.set_defaults(func=run)


def _write_png(path: Path, frame) -> None:
    import cv2

    if not cv2.imwrite(str(path), cv2.cvtColor(frame, cv2.COLOR_RGB2BGR)):
        raise FileNotFoundError(f"could not write {path}")


def _check_env_id(env_id: str) -> bool:
    """ValueError unless ``env_id`` is registered and renders rgb_array frames; True for FLUIDS
    ids."""
    import gymnasium as gym
    from gymnasium.envs.registration import load_env_creator

    from fluids_bench.registration import ENV_SPECS

    if env_id not in gym.registry:
        raise ValueError(f"--env is {env_id!r}; registered ids: {', '.join(sorted(ENV_SPECS))}")
    entry_point = gym.spec(env_id).entry_point
    metadata = getattr(load_env_creator(entry_point), "metadata", {})
    if "rgb_array" not in metadata.get("render_modes", []):
        raise ValueError(f"--env {env_id} does not render rgb_array frames: it has no demo")
    return entry_point == FLUIDS_ENTRY_POINT


def _load_kernels(env_id: str, kwargs: dict[str, Any]) -> None:
    """A few throwaway steps, so that loading the compiled kernels (compiling them, on a
    machine's first run: a few seconds) is not counted in the episode's steps per second."""
    import gymnasium as gym

    from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY

    env = gym.make(env_id, **kwargs)
    _, info = env.reset(seed=0)
    if SUPERVISOR_ACTION_KEY not in info:
        raise ValueError(f"--env {env_id} has no supervisor (no info['supervisor_action'])")
    for _ in range(10):
        _, _, terminated, truncated, info = env.step(info["supervisor_action"])
        if terminated or truncated:
            break
    env.close()


def _open_video(path: Path, fps: float):
    import imageio.v2 as imageio

    return imageio.get_writer(
        path,
        fps=fps,
        codec="libx264",
        quality=7,
        macro_block_size=16,
        pixelformat="yuv420p",
        ffmpeg_params=["-preset", "veryfast"],
    )


def run(args: argparse.Namespace) -> int:
    import gymnasium as gym
    import numpy as np

    import fluids_bench  # noqa: F401  (registers the env ids)
    from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY

    if args.steps is not None and args.steps < 1:
        raise ValueError(f"--steps is {args.steps}; allowed: an integer >= 1")
    fluids = _check_env_id(args.env)
    if args.steps is not None:
        kwargs_limit = {"max_episode_steps": args.steps}
    else:
        kwargs_limit = {}
    kwargs: dict[str, Any] = {}
    if args.layout is not None:
        if not fluids:
            raise ValueError(f"--layout applies to FLUIDS ids only, not to {args.env}")
        kwargs["layout"] = args.layout
    _load_kernels(args.env, kwargs)
    env = gym.make(args.env, render_mode="rgb_array", **kwargs_limit, **kwargs)
    args.out.mkdir(parents=True, exist_ok=True)
    obs, info = env.reset(seed=args.seed)
    sim = env.unwrapped
    if fluids:
        centre = np.mean(np.reshape(sim.world.layout.bounds, (2, 2)), axis=0)

    def ego_distance() -> float:
        return float(np.hypot(*(sim.world.state[0, :2] - centre)))

    writer = None
    if not args.no_video:
        writer = _open_video(args.out / VIDEO_NAME, env.metadata.get("render_fps", 10))
    # snapshot: FLUIDS, the lowest score (ego distance to the centre; a collision, -1, wins);
    # other envs, the last frame
    best, snapshot = np.inf, None

    def consider(score: float) -> None:
        nonlocal best, snapshot
        frame = None
        if writer is not None:
            frame = env.render()
            writer.append_data(frame)
        if not fluids or score < best:
            best = score
            snapshot = frame if frame is not None else env.render()

    consider(ego_distance() if fluids else 0.0)
    steps, collisions, sim_seconds, total = 0, [], 0.0, 0.0
    try:
        while True:
            t0 = time.perf_counter()
            obs, reward, terminated, truncated, info = env.step(info[SUPERVISOR_ACTION_KEY])
            sim_seconds += time.perf_counter() - t0
            steps += 1
            total += float(reward)
            if fluids:
                first_hit = bool(info["collisions"]) and not collisions
                collisions.extend(info["collisions"])
                consider(-1.0 if first_hit else ego_distance())
            else:
                consider(0.0)
            if terminated or truncated:
                break
    finally:
        if writer is not None:
            writer.close()
        env.close()
    _write_png(args.out / SNAPSHOT_NAME, snapshot)
    success = info.get("is_success")
    speed = (
        f"  simulation: {steps / max(sim_seconds, 1e-9):.0f} steps/s ({steps} steps in "
        f"{sim_seconds:.2f} s; drawing and video not counted)"
    )
    if fluids:
        ego = sum(1 for c in collisions if 0 in (c["a"], c["b"]))
        layout = args.layout or sim.scene.layout
        print(f"{args.env} demo: layout {layout}, seed {args.seed}, ego route {info['route']}")
        print(
            f"  success: {bool(success)}   steps: {steps}   collisions: {len(collisions)} "
            f"({ego} involving the ego)"
        )
    else:
        print(f"{args.env} demo: seed {args.seed}")
        shown = "n/a" if success is None else bool(success)
        print(f"  success: {shown}   return: {total:.3f}   steps: {steps}")
    print(speed)
    wrote = [str(args.out / SNAPSHOT_NAME)]
    if writer is not None:
        wrote.insert(0, f"{args.out / VIDEO_NAME} ({steps + 1} frames)")
    print("  wrote " + " and ".join(wrote))
    return 0
