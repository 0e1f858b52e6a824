"""The README's picture of the singulation supervisor at work: frames of one seeded episode.

Each panel is the env's own ``rgb_array`` frame at one step, with the supervisor's chosen push
(pre-push point and push line, an arrow) and the fingertip's path so far overlaid. Writes
``docs/images/singulation_supervisor.png`` (atomically). ``--seed`` picks the episode.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401
from fluids_bench.core import raster
from fluids_bench.core.provenance import announce
from fluids_bench.tasks.singulation import render

SIZE = 480
CROP = (slice(60, 480), slice(120, 360))  # rows, columns: the cluster and the arm


def overlay(frame: np.ndarray, env, path: list[tuple[float, float]]) -> np.ndarray:
    img = frame.copy()
    ppm = SIZE / render.VIEW_SIZE
    affine = raster.pixel_affine(ppm, render.VIEW_X0, render.VIEW_Y1)
    if len(path) > 1:
        pts = raster.to_fixed(affine, np.array(path))
        cv2.polylines(img, [pts], False, (40, 90, 200), 2, cv2.LINE_AA, raster.SHIFT)
    plan = env.unwrapped._supervisor.plan
    if plan is not None:
        start = plan.origin
        end = plan.origin + plan.end * plan.direction
        a, b = (raster.to_fixed(affine, p[None])[0] // raster.ONE for p in (start, end))
        cv2.arrowedLine(
            img, tuple(map(int, a)), tuple(map(int, b)), (20, 140, 40), 2, cv2.LINE_AA, 0, 0.3
        )
    return img


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--out", type=Path, default=Path("docs/images/singulation_supervisor.png"))
    args = parser.parse_args()
    announce("~10 s")

    env = gym.make("Singulation-v0", render_mode="rgb_array")
    env.unwrapped.RENDER_SIZE = SIZE
    _, info = env.reset(seed=args.seed)
    frames, path = [], [env.unwrapped.world.tip_xy()]
    frames.append((0, overlay(env.render(), env, path), info["progress"]))
    step, done = 0, False
    while not done:
        _, _, terminated, truncated, info = env.step(info["supervisor_action"])
        step += 1
        path.append(env.unwrapped.world.tip_xy())
        done = terminated or truncated
        frames.append((step, overlay(env.render(), env, path), info["progress"]))
    # four panels: start, mid-approach, start of the push, the end
    plan = env.unwrapped._supervisor.plan
    push_start = next(
        (
            k
            for k, p in enumerate(path)
            if plan is not None and np.hypot(*(np.array(p) - plan.origin)) < 0.004
        ),
        len(frames) // 2,
    )
    picks = sorted({0, max(1, push_start // 2), push_start, len(frames) - 1})
    panels = []
    for k in picks:
        n, img, prog = frames[k]
        img = np.ascontiguousarray(img[CROP])
        label = f"step {n}: progress {100 * prog:.1f} cm"
        cv2.putText(img, label, (6, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
        panels.append(img)
        panels.append(np.full((img.shape[0], 4, 3), 255, np.uint8))
    strip = np.concatenate(panels[:-1], axis=1)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".tmp.png")
    cv2.imwrite(str(tmp), cv2.cvtColor(strip, cv2.COLOR_RGB2BGR))
    os.replace(tmp, args.out)
    print(f"wrote {args.out} ({len(frames) - 1} steps, success: {info['is_success']})")


if __name__ == "__main__":
    main()
