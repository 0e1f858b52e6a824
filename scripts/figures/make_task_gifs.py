"""The moving pictures of the task pages and the gallery's thumbnails, from the envs themselves.

``python scripts/figures/make_task_gifs.py`` runs one seeded episode of each page's id with its
supervisor acting (the executed action is ``info["supervisor_action"]``; on the PettingZoo id every
agent follows its own label), takes the env's own ``rgb_array`` render every ``every`` steps, and
writes under ``docs/images/``:

- ``anim_<name>.gif``: the episode as a looping GIF (frames shrunk to ``size`` px on their long
  side, one shared 64-colour palette, under 400 KB each);
- ``thumb_<family>.png``: one frame of it, for the gallery (a readable picture of the task, at
  least 160 px on each side, where the filmstrips it replaces were 26 px tall at gallery width).

Seeded, so a rerun gives the same pictures. ``--only NAME ...`` remakes some of them. About a
minute on one core (FLUIDS compiles its kernels on a machine's first run; MuJoCo renders
off-screen through ``MUJOCO_GL``, egl or osmesa).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from pathlib import Path

import gymnasium as gym
import numpy as np
from PIL import Image

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core.provenance import announce
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY

IMAGES = Path(__file__).resolve().parents[2] / "docs" / "images"
MAX_BYTES = 400_000  # the pages load every GIF: each stays small


@dataclass(frozen=True)
class Movie:
    """One GIF: the id, its kwargs, the episode's length and which frame is the thumbnail."""

    env_id: str
    steps: int  # at most this many env steps
    every: int  # a frame every `every` steps
    size: int = 240  # px on the frame's long side
    seed: int = 0
    kwargs: dict = field(default_factory=dict)
    thumb: str = ""  # the gallery family this GIF gives its thumbnail to ("" none)
    thumb_at: float = 0.5  # which frame, as a fraction of the episode


MOVIES: dict[str, Movie] = {
    "fluids_v4": Movie("FLUIDS-v4", 150, 2, size=320, seed=4, thumb="fluids", thumb_at=0.5),
    "fluids_v1": Movie("FLUIDS-v1", 150, 2, size=320, seed=4),
    "fluids_v3": Movie("FLUIDS-v3", 150, 2, size=320, seed=4),
    "fluids_multi_agent": Movie(
        "FLUIDS-MultiAgent-v4", 150, 2, size=320, seed=7, thumb="fluids-multi-agent"
    ),
    "gridworld": Movie("GridWorld-v0", 60, 1, size=200, seed=0, thumb="gridworld", thumb_at=0.4),
    "dag": Movie("DAG-v0", 10, 1, size=280, thumb="dag", thumb_at=0.0),
    "singulation": Movie("Singulation-v0", 200, 1, thumb="singulation", thumb_at=0.6),
    "grasping": Movie("GraspingInClutter-v1", 200, 1, thumb="grasping", thumb_at=0.7),
    "track": Movie("DrivingTrack-v0", 240, 3, thumb="track", thumb_at=0.5),
    "locomotion": Movie(
        "Hopper-IL-v0", 240, 4, size=200, kwargs={"width": 200, "height": 200}, thumb="locomotion"
    ),
}


def _episode_gym(movie: Movie) -> tuple[list[np.ndarray], float]:
    env = gym.make(movie.env_id, render_mode="rgb_array", **movie.kwargs)
    _, info = env.reset(seed=movie.seed)
    frames = [env.render()]
    for t in range(1, movie.steps + 1):
        _, _, terminated, truncated, info = env.step(info[SUPERVISOR_ACTION_KEY])
        if t % movie.every == 0 or terminated or truncated:
            frames.append(env.render())
        if terminated or truncated:
            break
    fps = env.metadata.get("render_fps") or 10
    env.close()
    return frames, fps


def _episode_parallel(movie: Movie) -> tuple[list[np.ndarray], float]:
    from fluids_bench.registration import make_parallel_env

    env = make_parallel_env(movie.env_id, render_mode="rgb_array", **movie.kwargs)
    _, infos = env.reset(seed=movie.seed)
    frames = [env.render()]
    for t in range(1, movie.steps + 1):
        actions = {a: infos[a][SUPERVISOR_ACTION_KEY] for a in env.agents}
        _, _, _, _, infos = env.step(actions)
        if t % movie.every == 0 or not env.agents:
            frames.append(env.render())
        if not env.agents:
            break
    fps = env.metadata.get("render_fps") or 10
    env.close()
    return frames, fps


def episode(movie: Movie) -> tuple[list[np.ndarray], float]:
    """The rendered frames of one supervised episode and the env's frames per second."""
    from fluids_bench.registration import PARALLEL_ENV_SPECS

    if movie.env_id in PARALLEL_ENV_SPECS:
        return _episode_parallel(movie)
    return _episode_gym(movie)


def shrink(frame: np.ndarray, size: int) -> Image.Image:
    image = Image.fromarray(np.ascontiguousarray(frame[..., :3]))
    scale = size / max(image.size)
    if scale < 1:
        image = image.resize(
            (round(image.width * scale), round(image.height * scale)), Image.Resampling.LANCZOS
        )
    return image


def write_gif(path: Path, images: list[Image.Image], seconds_per_frame: float) -> int:
    """A looping GIF with one palette for all frames (no flicker); returns its size in bytes."""
    palette = images[len(images) // 2].quantize(colors=64, method=Image.Quantize.MEDIANCUT)
    frames = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
    tmp = path.with_suffix(".tmp.gif")
    frames[0].save(
        tmp,
        save_all=True,
        append_images=frames[1:],
        duration=max(20, round(1000 * seconds_per_frame)),
        loop=0,
        optimize=True,
        disposal=1,
    )
    tmp.replace(path)
    return path.stat().st_size


def make(name: str, movie: Movie, out: Path) -> None:
    frames, fps = episode(movie)
    images = [shrink(f, movie.size) for f in frames]
    seconds_per_frame = movie.every / fps
    # a still-life env (the DAG, 1 fps) is shown slowly; a fast one no faster than 20 fps
    size = write_gif(out / f"anim_{name}.gif", images, max(seconds_per_frame, 0.05))
    if size > MAX_BYTES:
        raise RuntimeError(f"anim_{name}.gif is {size} bytes; allowed: {MAX_BYTES} (shrink it)")
    line = f"anim_{name}.gif: {len(images)} frames of {images[0].size}, {size // 1000} KB"
    if movie.thumb:
        thumb = shrink(frames[round(movie.thumb_at * (len(frames) - 1))], 320)
        path = out / f"thumb_{movie.thumb}.png"
        tmp = path.with_suffix(".tmp.png")
        thumb.save(tmp, optimize=True)
        tmp.replace(path)
        line += f"; thumb_{movie.thumb}.png {thumb.size}"
    print(line, flush=True)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--only", nargs="+", choices=list(MOVIES), default=list(MOVIES))
    p.add_argument("--out", type=Path, default=IMAGES)
    args = p.parse_args(argv)
    announce("about a minute on one core")
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.only:
        make(name, MOVIES[name], args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
