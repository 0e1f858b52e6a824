"""The sensitivity plot (the source's Fig. 7.6): success rate against each normalised parameter.

For every parameter and each of its values, the success rate over all episodes of all
configurations with that value (the marginal over the other parameters); the x axis maps each
parameter's grid range to [0, 1], one line per parameter.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

from fluids_bench.algos.plots import new_figure, save_png_atomic
from fluids_bench.sweep.grid import ORDER, PARAMETERS, Grid


def marginals(
    rows: Sequence[Mapping[str, Any]], grid: Grid
) -> dict[str, list[tuple[float, float]]]:
    """``{parameter: [(normalised value, success rate), ...]}`` over the rows given."""
    out: dict[str, list[tuple[float, float]]] = {}
    for name in ORDER:
        points = []
        for value in grid.values[name]:
            chosen = [r for r in rows if float(r[name]) == float(value)]
            episodes = sum(int(r["episodes"]) for r in chosen)
            if episodes:
                successes = sum(int(r["successes"]) for r in chosen)
                points.append((grid.normalise(name, value), successes / episodes))
        out[name] = points
    return out


def _label(name: str, grid: Grid) -> str:
    values = grid.values[name]
    if PARAMETERS[name][0] == "bool":
        return f"{name.replace('_', ' ')} (off→on)"
    unit = " kg" if name == "car_mass" else ""
    return f"{name.replace('_', ' ')} ({values[0]:g}–{values[-1]:g}{unit})"


def plot_sensitivity(
    rows: Sequence[Mapping[str, Any]],
    grid: Grid,
    path: str | os.PathLike[str],
    title: str | None = None,
) -> None:
    """Write the PNG (atomically) for the rows finished so far."""
    figure = new_figure(size=(7.0, 4.5))
    (axes,) = figure.axes
    drawn = False
    for name, points in marginals(rows, grid).items():
        if points:
            drawn = True
            xs, ys = zip(*points, strict=True)
            axes.plot(xs, ys, marker="o", label=_label(name, grid))
    episodes = sum(int(r["episodes"]) for r in rows)
    axes.set_xlabel("normalised parameter value")
    axes.set_ylabel("success rate (every car reaches its goal)")
    axes.set_xlim(-0.03, 1.03)
    axes.set_ylim(-0.02, 1.02)
    axes.set_title(
        title
        or f"Sensitivity of the learned policy: {len(rows)} of {len(grid)} "
        f"configurations, {episodes} episodes",
        fontsize="medium",
    )
    save_png_atomic(figure, path, legend_loc="best" if drawn else None)
