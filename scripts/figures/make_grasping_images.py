"""The README picture of the grasping supervisor at work: frames of one seeded episode, side by side.

Each frame is ``env.render()`` (``render_mode="rgb_array"``) with the corridor the supervisor's
label follows drawn over it (the line from the lead-in point to the target; none on the line
phases, which need no corridor) and the waypoint phase as a caption. Usage: ``python scripts/figures/make_grasping_images.py`` (writes
``docs/images/grasping_supervisor.png``). Needs the package importable.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.results import write_bytes_atomic
from fluids_bench.core.provenance import announce
from fluids_bench.core.raster import SHIFT, to_fixed
from fluids_bench.tasks.grasping.render import view
from fluids_bench.tasks.grasping.sim import TARGET
from fluids_bench.tasks.grasping.supervisor import LEAD_IN, GraspSupervisor


def annotated_frame(env: gym.Env, caption: str, sup: GraspSupervisor) -> np.ndarray:
    inner = env.unwrapped
    frame = env.render().copy()
    plan = sup.plan_
    if plan is not None:
        affine, _ = view(inner.cfg, frame.shape[0])
        tx, ty = inner.world.state.poses[TARGET, :2]
        h = plan.corridor.heading
        ends = np.array([[tx - LEAD_IN * math.cos(h), ty - LEAD_IN * math.sin(h)], [tx, ty]])
        a, b = to_fixed(affine, ends)
        cv2.line(frame, tuple(a), tuple(b), (250, 220, 60), 2, cv2.LINE_AA, SHIFT)
    cv2.putText(frame, caption, (10, 26), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 2)
    return frame


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=11)
    parser.add_argument("--size", type=int, default=360)
    parser.add_argument("--out", type=Path, default=Path("docs/images/grasping_supervisor.png"))
    args = parser.parse_args()
    announce("~10 s")
    env = gym.make("GraspingInClutter-v0", render_mode="rgb_array", render_size=args.size)
    _, info = env.reset(seed=args.seed)
    sup = GraspSupervisor(env.unwrapped.cfg)  # labels depend on the state only: same labels
    frames, seen, step, done = [], set(), 0, False
    while not done:
        _, phase = sup.decide(env.unwrapped.world)
        if phase not in seen:
            seen.add(phase)
            frames.append(annotated_frame(env, f"t={step} {phase}", sup))
        _, _, terminated, truncated, info = env.step(info["supervisor_action"])
        step += 1
        done = terminated or truncated
    outcome = "grasped" if info["grasped"] else "no grasp"
    sup.decide(env.unwrapped.world)
    frames.append(annotated_frame(env, f"t={step} {outcome}, cost {info['cost']:g}", sup))
    picked = frames if len(frames) <= 5 else [*frames[:4], frames[-1]]
    strip = np.concatenate([np.pad(f, ((4, 4), (4, 4), (0, 0))) for f in picked], axis=1)
    ok, png = cv2.imencode(".png", cv2.cvtColor(strip, cv2.COLOR_RGB2BGR))
    assert ok
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_bytes_atomic(args.out, png.tobytes())
    print(f"wrote {args.out} ({len(picked)} frames, {outcome})")


if __name__ == "__main__":
    main()
