"""A filmstrip of each locomotion IL env with its supervisor driving, for the README.

``python scripts/figures/make_locomotion_images.py --env Hopper-IL-v0 --steps 120 --every 30`` writes
``docs/images/locomotion_hopper.png``: frames at steps 0, 30, 60, ... side by side, rendered by
Gymnasium's MuJoCo renderer in ``rgb_array`` mode. Seeded, so reruns give the same picture.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core.provenance import announce


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", nargs="+", default=["Hopper-IL-v0"])
    p.add_argument("--kind", default=None, help="supervisor kind (default: the id's)")
    p.add_argument("--steps", type=int, default=120)
    p.add_argument("--every", type=int, default=30)
    p.add_argument("--size", type=int, default=240)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=Path("docs/images"))
    args = p.parse_args(argv)
    announce("~30 s per id")
    args.out.mkdir(parents=True, exist_ok=True)
    for env_id in args.env:
        kwargs = {} if args.kind is None else {"supervisor": args.kind}
        env = gym.make(env_id, render_mode="rgb_array", width=args.size, height=args.size, **kwargs)
        _, info = env.reset(seed=args.seed)
        frames = []
        for t in range(args.steps + 1):
            if t % args.every == 0:
                frames.append(env.render())
            _, _, terminated, truncated, info = env.step(info["supervisor_action"])
            if terminated or truncated:
                break
        strip = np.concatenate(frames, axis=1)
        path = args.out / f"locomotion_{env_id.split('-')[0].lower()}.png"
        cv2.imwrite(
            str(path), cv2.cvtColor(strip, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_PNG_COMPRESSION, 9]
        )
        print(path, strip.shape)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
