"""The pictures of the GridWorld and DAG task pages (and of the site's gallery).

``python scripts/figures/make_task_images.py`` writes

- ``docs/images/task_gridworld.png``: a filmstrip of one seeded GridWorld-v0 episode driven by
  its value-iteration supervisor, from the env's own ``rgb_array`` render (every ``--every``
  steps; the cells visited so far are dotted);
- ``docs/images/task_dag.png``: the decision DAG of DAG-v0 drawn with matplotlib (the env has no
  renderer), every edge with its reward, the greedy supervisor's label at each node in bold and
  the root's slip dashed.

Seeded: a rerun gives the same pictures. A few seconds on one core.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
import imageio.v3 as iio
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core.provenance import announce
from fluids_bench.tasks.dag.model import DEPTH, EDGE_REWARDS, L, R
from fluids_bench.tasks.dag.supervisor import expected_return, greedy_action

IMAGES = Path(__file__).resolve().parents[2] / "docs" / "images"
TRAIL = np.array([40, 40, 40], dtype=np.uint8)
GAP = 6  # white pixels between frames


def gridworld_filmstrip(world_seed: int, seed: int, every: int) -> np.ndarray:
    """Frames of one supervised episode side by side, visited cells dotted."""
    env = gym.make("GridWorld-v0", world_seed=world_seed, render_mode="rgb_array")
    base = env.unwrapped
    _, info = env.reset(seed=seed)
    visited = [base.world.cell(base._state)]  # noqa: SLF001  (the drawing reads the env's cell)
    frames, t, done = [], 0, False
    while True:
        if t % every == 0 or done:
            frames.append(_dotted(env.render(), visited, base.size))
        if done:
            break
        _, _, terminated, truncated, info = env.step(info["supervisor_action"])
        visited.append(base.world.cell(base._state))  # noqa: SLF001
        t += 1
        done = terminated or truncated
    env.close()
    height = frames[0].shape[0]
    gap = np.full((height, GAP, 3), 255, dtype=np.uint8)
    parts = [p for frame in frames for p in (frame, gap)][:-1]
    return np.concatenate(parts, axis=1)


def _dotted(frame: np.ndarray, cells: list[tuple[int, int]], size: int) -> np.ndarray:
    """``frame`` with a small dot in every cell of ``cells`` (forward, y + 1, points up)."""
    out = frame.copy()
    pixels = frame.shape[0] // size
    r = max(1, pixels // 6)
    for x, y in cells[:-1]:  # the current cell is drawn by the env itself
        row, col = (size - 1 - int(y)) * pixels + pixels // 2, int(x) * pixels + pixels // 2
        out[row - r : row + r, col - r : col + r] = TRAIL
    return out


def dag_picture(path: Path, mu: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def position(level: int, index: int) -> tuple[float, float]:
        return index - level / 2, -float(level)

    fig, ax = plt.subplots(figsize=(6.4, 4.6), dpi=120)
    for level in range(DEPTH):
        for index in range(level + 1):
            x0, y0 = position(level, index)
            label = greedy_action(level, index)
            for move in (L, R):
                x1, y1 = position(level + 1, index + move)
                chosen = move == label
                ax.annotate(
                    "",
                    xy=(x1, y1 + 0.12),
                    xytext=(x0, y0 - 0.12),
                    arrowprops={
                        "arrowstyle": "-|>",
                        "lw": 3.0 if chosen else 1.0,
                        "color": "tab:green" if chosen else "0.55",
                    },
                )
                xm, ym = x0 + 0.3 * (x1 - x0), y0 + 0.3 * (y1 - y0)  # near the node it leaves
                ax.text(
                    xm + (-0.08 if move == L else 0.08),
                    ym,
                    f"{'LR'[move]} {EDGE_REWARDS[level][index][move]:g}",
                    ha="right" if move == L else "left",
                    va="center",
                    fontsize=9,
                    fontweight="bold" if chosen else "normal",
                )
    # the root's slip: L there reaches the right child with probability mu
    x0, y0 = position(0, 0)
    x1, y1 = position(1, 1)
    ax.annotate(
        "",
        xy=(x1 - 0.05, y1 + 0.2),
        xytext=(x0 - 0.1, y0 - 0.2),
        arrowprops={
            "arrowstyle": "-|>",
            "ls": "--",
            "color": "tab:red",
            "connectionstyle": "arc3,rad=-0.5",
        },
    )
    ax.text(0.45, 0.0, f"L slips to R\nwith μ = {mu:g}", color="tab:red", fontsize=8, va="center")
    for level in range(DEPTH + 1):
        for index in range(level + 1):
            x, y = position(level, index)
            ax.scatter([x], [y], s=420, color="white", edgecolors="black", zorder=3)
            ax.text(x, y, f"{level},{index}", ha="center", va="center", fontsize=7, zorder=4)
    sup, left, right = (expected_return(mu, p) for p in ("supervisor", "L", "R"))
    ax.set_title(
        f"DAG-v0: the supervisor's labels in bold green\n"
        f"expected return: supervisor {sup:g}, constant L {left:g}, constant R {right:g}",
        fontsize=10,
    )
    ax.set_xlim(-2.0, 2.0)
    ax.set_ylim(-DEPTH - 0.4, 0.4)
    ax.axis("off")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--world-seed", type=int, default=0, help="GridWorld-v0's world")
    p.add_argument("--seed", type=int, default=0, help="the episode's reset seed")
    p.add_argument("--every", type=int, default=6, help="a frame every k steps")
    p.add_argument("--mu", type=float, default=0.25, help="DAG-v0's root slip")
    p.add_argument("--out", type=Path, default=IMAGES)
    args = p.parse_args(argv)
    announce("~10 s")
    if args.every < 1:
        p.error("--every must be >= 1")
    args.out.mkdir(parents=True, exist_ok=True)
    strip = gridworld_filmstrip(args.world_seed, args.seed, args.every)
    iio.imwrite(args.out / "task_gridworld.png", strip)
    print(args.out / "task_gridworld.png", strip.shape)
    dag_picture(args.out / "task_dag.png", args.mu)
    print(args.out / "task_dag.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
