"""The README picture of DrivingTrack: tracks with the supervisor's two laps drawn on them.

Each panel is one track (``track_seed``) at drawing resolution with the path of the default
supervisor (depth 8, blue) and of the source-like one (depth 1, orange); crosses mark where a
car left the road (it is put back on the centre line ahead of that point), and the title
gives each one's crashes. Below each panel, the 125×125 image the learner sees.
Usage: ``python scripts/figures/make_track_image.py`` (writes docs/images/track_laps.png).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401
from fluids_bench.algos.results import write_bytes_atomic
from fluids_bench.core.provenance import announce
from fluids_bench.core.raster import SHIFT, to_fixed
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY

DRIVERS = ((8, (30, 90, 220)), (1, (245, 140, 20)))  # depth, RGB


def drive(track_seed: int, depth: int):
    env = gym.make("DrivingTrack-v0", obs_type="pixels", depth=depth, track_seed=track_seed,
                   render_mode="rgb_array")  # fmt: skip
    obs, info = env.reset(seed=track_seed)
    sim = env.unwrapped.sim
    path, crashes, done = [[(sim.car.x, sim.car.y)]], [], False
    first = obs
    while not done:
        before = (sim.car.x, sim.car.y, sim.car.heading)
        _, _, terminated, truncated, info = env.step(info[SUPERVISOR_ACTION_KEY])
        done = terminated or truncated
        if info["crashed"]:
            crashes.append(before[:2])  # the last pose on the road before it left
            path.append([])
        path[-1].append((sim.car.x, sim.car.y))
    return env, path, crashes, info["crashes"], first


def panel(track_seed: int) -> np.ndarray:
    image = None
    texts = []
    for depth, colour in DRIVERS:
        env, path, crashes, total, first = drive(track_seed, depth)
        view = env.unwrapped.view
        if image is None:
            image = view.background.copy()
            small = first
        for piece in path:
            if len(piece) > 1:
                pts = to_fixed(view.affine, np.array(piece))
                cv2.polylines(image, [pts], False, colour, 2, cv2.LINE_AA, SHIFT)
        for x, y in crashes:
            u, v = to_fixed(view.affine, np.array([[x, y]]))[0] >> SHIFT
            cv2.drawMarker(image, (int(u), int(v)), colour, cv2.MARKER_TILTED_CROSS, 12, 2)
        texts.append((f"depth {depth}: {total} crashes / 2 laps", colour))
    for i, (text, colour) in enumerate(texts):
        cv2.putText(image, text, (10, 25 + 25 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.6, colour, 2,
                    cv2.LINE_AA)  # fmt: skip
    cv2.putText(image, f"track_seed={track_seed}", (10, 490), cv2.FONT_HERSHEY_SIMPLEX, 0.5,
                (255, 255, 255), 1, cv2.LINE_AA)  # fmt: skip
    # the learner's 125x125 view, enlarged 2x, in the bottom-right corner
    inset = cv2.resize(small, (250, 250), interpolation=cv2.INTER_NEAREST)
    image[-252:-2, -252:-2] = inset
    cv2.rectangle(image, (image.shape[1] - 253, image.shape[0] - 253),
                  (image.shape[1] - 2, image.shape[0] - 2), (255, 255, 255), 1)  # fmt: skip
    return image


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tracks", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--out", type=Path, default=Path("docs/images/track_laps.png"))
    args = parser.parse_args()
    announce("~20 s")
    panels = [panel(t) for t in args.tracks]
    gap = np.full((panels[0].shape[0], 6, 3), 255, np.uint8)
    row = np.concatenate(
        [p for pair in zip(panels, [gap] * len(panels), strict=True) for p in pair][:-1], 1
    )
    ok, png = cv2.imencode(".png", row[..., ::-1])  # RGB -> OpenCV's BGR
    assert ok
    write_bytes_atomic(args.out, png.tobytes())
    print(args.out)


if __name__ == "__main__":
    main()
