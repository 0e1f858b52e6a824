"""`fluids-bench demo`: one seeded episode of any registered id under its supervisor.

The controlled agent follows the supervisor's label (`info["supervisor_action"]`) every
step; for the multi-agent ids (PettingZoo ParallelEnvs, built with
`fluids_bench.registration.make_parallel_env`) every agent follows its own label. The command
prints a summary and writes, under `--out` (default `fluids_demo/<ID>/`, one folder per id):

* `episode.png`, a snapshot: for FLUIDS ids the first collision if there is one, else the ego
  nearest the junction's centre (candidates are drawn as the episode goes, about 2 ms each);
  for the others the last frame, and with `--no-video` that one frame is all that is drawn;
* `episode.mp4` (unless `--no-video`): every `--frame-every`-th step and the last, played
  in real time. By default the stride keeps drawing to about 15 s (MuJoCo's software renderer
  takes ~0.1 s a frame, so a 1,000-step locomotion episode is drawn every 7th step or so;
  FLUIDS, ~2 ms a frame, every step). The summary says which stride was used;
* for an id whose actions are named decisions (`DAG-v0`), or one without pictures, also
  `episode.txt`: the episode as text, one line per step, also printed.

A progress bar counts steps on stderr (`--no-progress` hides it). `--steps N` cuts the
episode after N steps (the tests run every id that way). Steps per second time `env.step`
alone: drawing and encoding are not counted, and the env's compiled kernels (if any) are loaded
in a throwaway env first. MuJoCo's compiler warnings go to Python's `warnings`, not to a
`MUJOCO_LOG.TXT` in the working directory (`fluids_bench.tasks.locomotion.env`).

Examples:

    fluids-bench demo --seed 3 --layout roundabout --steps 300
    fluids-bench demo --env Hopper-IL-v0 --no-video
    fluids-bench demo --env FLUIDS-MultiAgent-v1 --out multi_demo
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from fluids_bench.commands import plain_text
from fluids_bench.commands.demo_output import (
    SNAPSHOT_NAME,
    Recorder,
    progress_bar,
    write_png,
)
from fluids_bench.tasks.fluids.sim.config import LAYOUTS

TEXT_NAME = "episode.txt"
DEFAULT_ENV = "FLUIDS-v4"
DEFAULT_OUT = Path("fluids_demo")
FLUIDS_ENTRY_POINT = "fluids_bench.tasks.fluids.env:FluidsEnv"
# names of Discrete actions for the text trace, where an id has them
ACTION_NAMES = {"DAG-v0": ("L", "R")}


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = subparsers.add_parser(
        "demo",
        help="run a seeded episode under the supervisor (default FLUIDS-v4); write an MP4 and a PNG",
        description=plain_text(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--env",
        default=DEFAULT_ENV,
        help=f"registered Gymnasium or PettingZoo id (default {DEFAULT_ENV})",
    )
    p.add_argument("--seed", type=int, default=0, help="episode seed (default 0)")
    p.add_argument(
        "--layout", choices=LAYOUTS, default=None, help="FLUIDS ids only (default four_way)"
    )
    p.add_argument(
        "--steps", type=int, default=None, help="most steps to run (default: the id's limit)"
    )
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        help=f"output folder (default {DEFAULT_OUT}/<ID>)",
    )
    p.add_argument(
        "--no-video", action="store_true", help="skip the MP4 (the PNG is still written)"
    )
    p.add_argument(
        "--frame-every",
        type=int,
        default=None,
        metavar="K",
        help="video: draw every K-th step (default: a stride that keeps drawing to ~15 s)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def _registered(env_id: str) -> str:
    """`"gym"` or `"pettingzoo"`: which registry holds `env_id`; ValueError if neither."""
    import gymnasium as gym

    import fluids_bench  # noqa: F401  (registers the env ids)
    from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS

    if env_id in PARALLEL_ENV_SPECS:
        return "pettingzoo"
    if env_id not in gym.registry:
        raise ValueError(
            f"--env is {env_id!r}; allowed: a Gymnasium id ({', '.join(sorted(ENV_SPECS))}) "
            f"or a PettingZoo id ({', '.join(sorted(PARALLEL_ENV_SPECS))})"
        )
    return "gym"


def _draws(env_id: str) -> bool:
    """Whether `env_id` renders rgb_array frames (else the demo writes text)."""
    import gymnasium as gym
    from gymnasium.envs.registration import load_env_creator

    metadata = getattr(load_env_creator(gym.spec(env_id).entry_point), "metadata", {})
    return "rgb_array" in metadata.get("render_modes", [])


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


def run(args: argparse.Namespace) -> int:
    if args.steps is not None and args.steps < 1:
        raise ValueError(f"--steps is {args.steps}; allowed: an integer >= 1")
    if args.frame_every is not None and args.frame_every < 1:
        raise ValueError(f"--frame-every is {args.frame_every}; allowed: an integer >= 1")
    registry = _registered(args.env)
    if args.out is None:
        args.out = DEFAULT_OUT / args.env
    if registry == "pettingzoo":
        from fluids_bench.commands.demo_multi import run_parallel

        return run_parallel(args)
    return _run_gym(args)


def _run_gym(args: argparse.Namespace) -> int:
    import gymnasium as gym
    import numpy as np

    from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY

    fluids = gym.spec(args.env).entry_point == FLUIDS_ENTRY_POINT
    kwargs: dict[str, Any] = {}
    if args.layout is not None:
        if not fluids:
            raise ValueError(f"--layout applies to FLUIDS ids only, not to {args.env}")
        kwargs["layout"] = args.layout
    draws = _draws(args.env)
    _load_kernels(args.env, kwargs)
    limit_kwargs = {} if args.steps is None else {"max_episode_steps": args.steps}
    render_kwargs = {"render_mode": "rgb_array"} if draws else {}
    env = gym.make(args.env, **render_kwargs, **limit_kwargs, **kwargs)
    limit = env.spec.max_episode_steps
    args.out.mkdir(parents=True, exist_ok=True)
    obs, info = env.reset(seed=args.seed)
    sim = env.unwrapped
    traced = not draws or args.env in ACTION_NAMES  # a text trace too (or instead)
    trace = [f"reset: observation {_text(obs)}"] if traced else []
    recorder = None
    if draws:
        fps = env.metadata.get("render_fps") or 10
        recorder = Recorder(env.render, args.out, fps, not args.no_video, args.frame_every, limit)
    if fluids:
        centre = np.mean(np.reshape(sim.world.layout.bounds, (2, 2)), axis=0)

    def ego_distance() -> float:
        return float(np.hypot(*(sim.world.state[0, :2] - centre)))

    # FLUIDS' snapshot: the lowest score (ego distance to the centre; a collision, -1, wins)
    best = np.inf

    def consider(step: int, score: float, last: bool) -> None:
        nonlocal best
        frame = recorder.frame(step, last)
        if fluids and score < best:
            best = score
            recorder.snapshot = frame if frame is not None else env.render()
        elif not fluids and last:
            recorder.snapshot = frame if frame is not None else env.render()

    steps, collisions, sim_seconds, total = 0, [], 0.0, 0.0
    bar = progress_bar(limit, args.env, args.no_progress)
    try:
        if recorder is not None:
            consider(0, ego_distance() if fluids else 0.0, False)
        while True:
            action = info[SUPERVISOR_ACTION_KEY]
            t0 = time.perf_counter()
            obs, reward, terminated, truncated, info = env.step(action)
            sim_seconds += time.perf_counter() - t0
            steps += 1
            total += float(reward)
            bar.update(1)
            done = terminated or truncated
            if traced:
                trace.append(_trace_line(args.env, steps, action, reward, obs))
            if recorder is None:
                pass
            elif fluids:
                first_hit = bool(info["collisions"]) and not collisions
                collisions.extend(info["collisions"])
                consider(steps, -1.0 if first_hit else ego_distance(), done)
            else:
                consider(steps, 0.0, done)
            if done:
                break
    finally:
        bar.close()
        if recorder is not None:
            recorder.close()
        env.close()
    wrote = []
    if recorder is not None:
        write_png(args.out / SNAPSHOT_NAME, recorder.snapshot)
        wrote = recorder.wrote()
    if traced:
        (args.out / TEXT_NAME).write_text("\n".join(trace) + "\n")
        wrote.append(str(args.out / TEXT_NAME))
    success = info.get("is_success")
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
        if "crashes" in info and "laps" in info:  # DrivingTrack: what the viewer sees
            print(
                f"  crashes: {info['crashes']} in {info['laps']:.2f} laps; a crash puts the car "
                "back on the road a little ahead and it drives on (return = -crashes; success "
                "= a lap without a crash)"
            )
        for line in trace:
            print("  " + line)
    print(
        f"  simulation: {steps / max(sim_seconds, 1e-9):.0f} steps/s ({steps} steps in "
        f"{sim_seconds:.2f} s; drawing and video not counted)"
    )
    print("  wrote " + " and ".join(wrote))
    return 0


def _text(values) -> str:
    import numpy as np

    return np.array2string(np.asarray(values), precision=3, separator=", ")


def _trace_line(env_id: str, step: int, action, reward: float, obs) -> str:
    names = ACTION_NAMES.get(env_id)
    shown = names[int(action)] if names is not None else _text(action)
    return (
        f"step {step}: the supervisor chose {shown}, reward {float(reward):.3f}, "
        f"observation {_text(obs)}"
    )
