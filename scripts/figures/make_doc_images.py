"""Regenerate the pictures under docs/images/ (layouts, observation families, a demo frame).

Run from the repository root: ``python scripts/figures/make_doc_images.py [--out docs/images]``.
Everything is seeded, so the pictures only change when the simulator or the drawing does.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the env ids)
from fluids_bench.core.provenance import announce
from fluids_bench.tasks.fluids.sim.draw import visible_agents
from fluids_bench.tasks.fluids.sim.layout import build_layout, compile_layout
from fluids_bench.tasks.fluids.sim.render import RAY_LEGEND, Renderer, draw_legend, draw_rays
from fluids_bench.tasks.fluids.sim.sensors.birdseye import BirdsEyeSensor
from fluids_bench.tasks.fluids.sim.sensors.qlidar import QLidarSensor

SEED, STEP = 4, 75  # a scene with the ego at the junction and traffic around it
ZOOM = 4  # 84-pixel observations are shown enlarged (nearest neighbour) so pixels stay visible


def save(out: Path, name: str, rgb: np.ndarray) -> None:
    path = out / name
    cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_PNG_COMPRESSION, 9])
    print(f"{path}  {rgb.shape[1]}x{rgb.shape[0]}  {path.stat().st_size // 1024} KB")


def enlarge(img: np.ndarray, factor: int = ZOOM) -> np.ndarray:
    return cv2.resize(img, None, fx=factor, fy=factor, interpolation=cv2.INTER_NEAREST)


def layouts(out: Path) -> None:
    for name, kwargs in (
        ("four_way", {}),
        ("four_way_2lanes", {"lanes": 2}),
        ("t_junction", {}),
        ("roundabout", {}),
    ):
        spec = build_layout(name.replace("_2lanes", ""), **kwargs)
        save(out, f"layout_{name}.png", Renderer(compile_layout(spec), 512).render_layout())


def scene():
    env = gym.make("FLUIDS-v0", num_cars=8, num_pedestrians=4)
    _, info = env.reset(seed=SEED)
    for _ in range(STEP):
        _, _, term, trunc, info = env.step(info["supervisor_action"])
        if term or trunc:
            raise SystemExit("the chosen scene ended early; pick another SEED/STEP")
    return env.unwrapped.world


def observations(out: Path) -> None:
    world = scene()
    rng = np.random.default_rng(0)
    layout = world.layout
    save(out, "demo_frame.png", Renderer(layout, 512).render(world))
    for frame in ("ego", "ego_rotated", "global"):
        img = BirdsEyeSensor(layout, 84, 40.0, frame).observe(world, rng)
        save(out, f"obs_birdseye_{frame}.png", enlarge(img))
    save(
        out,
        "obs_birdseye_ego_400.png",
        BirdsEyeSensor(layout, 400, 40.0, "ego").observe(world, rng),
    )
    noisy = BirdsEyeSensor(layout, 84, 40.0, "ego", noise_var=400.0).observe(world, rng)
    save(out, "obs_birdseye_noise.png", enlarge(noisy))
    # quasi-LIDAR: the rays over a close-up of the global view, agents drawn again on top
    sensor = QLidarSensor(layout, 64, 30.0)
    reading = sensor.observe(world, rng)
    big = Renderer(layout, 1024, legend=False)
    frame = big.render(world)
    draw_rays(frame, big.affine, world, sensor.offsets, reading)
    big.painter.draw(frame, big.affine, world, visible_agents(world))
    u, v = (big.affine @ (*world.state[0, :2], 1.0)).round().astype(int)
    half = int(31 * big.ppm)
    u = int(np.clip(u, half, frame.shape[1] - half))
    v = int(np.clip(v, half, frame.shape[0] - half))
    crop = cv2.resize(
        frame[v - half : v + half, u - half : u + half], (512, 512), interpolation=cv2.INTER_AREA
    )
    draw_legend(crop, RAY_LEGEND, "bl", 0.45)
    save(out, "obs_qlidar.png", crop)


def collision(out: Path) -> None:
    """The render of a crash: the ego floors it (supervisor's steering, full throttle)."""
    env = gym.make("FLUIDS-v0", num_cars=8, num_pedestrians=4, render_mode="rgb_array")
    _, info = env.reset(seed=0)
    for _ in range(100):
        action = np.array([info["supervisor_action"][0], 1.0], np.float32)
        _, _, term, trunc, info = env.step(action)
        if info["collisions"]:
            save(
                out,
                "render_collision.png",
                cv2.resize(env.render(), (512, 512), interpolation=cv2.INTER_AREA),
            )
            return
        if term or trunc:
            break
    raise SystemExit("no collision in the chosen episode; pick another seed")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/images"))
    args = parser.parse_args()
    announce("~30 s")
    args.out.mkdir(parents=True, exist_ok=True)
    layouts(args.out)
    observations(args.out)
    collision(args.out)


if __name__ == "__main__":
    main()
