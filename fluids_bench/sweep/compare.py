"""Several policies swept over one grid, side by side: per-level statistics and the figure.

A sensitivity study sweeps the supervisor (the reference) and learners over the same grid. Each
factor's level pools the configurations with that value, each with the same number of
episodes, so the level's estimate is a stratified mean and its standard error is the sampling
error of the episodes:

* success: the pooled success rate p over N episodes, standard error sqrt(p (1 - p) / N)
  (the stratified error is at most this);
* return: the mean over the k configurations of their mean returns, standard error
  sqrt(sum_i s_i² / n_i) / k from each configuration's sample standard deviation s_i over its
  n_i episodes. Returns are shown divided by a reference (the supervisor's mean return at the
  nominal configuration), so learners and reference share one scale.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

from fluids_bench.algos.plots import new_figure, save_png_atomic
from fluids_bench.sweep.plot import RETURN, SUCCESS, row_matches


def level_stats(
    rows: Sequence[Mapping[str, Any]], grid: Any, metric: str
) -> dict[str, list[dict[str, Any]]]:
    """`{factor: [{"value", "configurations", "episodes", "metric", "stderr"}, ...]}`: the
    success rate, or the mean return (not normalised), of each level with its standard error."""
    if metric not in (SUCCESS, RETURN):
        raise ValueError(f"level_stats: field 'metric' is {metric!r}; allowed: success, return")
    out: dict[str, list[dict[str, Any]]] = {}
    for name in grid.names:
        levels = []
        for value in grid.values[name]:
            chosen = [r for r in rows if row_matches(r, name, value)]
            if not chosen:
                continue
            episodes = sum(int(r["episodes"]) for r in chosen)
            if metric == SUCCESS:
                p = sum(int(r["successes"]) for r in chosen) / episodes
                mean, stderr = p, math.sqrt(p * (1 - p) / episodes)
            else:
                k = len(chosen)
                mean = sum(float(r["mean_return"]) for r in chosen) / k
                variance = sum(float(r["std_return"]) ** 2 / int(r["episodes"]) for r in chosen)
                stderr = math.sqrt(variance) / k
            levels.append(
                {
                    "value": value,
                    "configurations": len(chosen),
                    "episodes": episodes,
                    "metric": mean,
                    "stderr": stderr,
                }
            )
        out[name] = levels
    return out


def nominal_row(
    rows: Sequence[Mapping[str, Any]], nominal: Mapping[str, Any]
) -> Mapping[str, Any] | None:
    """The row of the nominal configuration (every factor at its `nominal` value), if swept."""
    for row in rows:
        if all(row_matches(row, name, value) for name, value in nominal.items()):
            return row
    return None


def plot_policies(
    policies: Mapping[str, Sequence[Mapping[str, Any]]],
    grid: Any,
    metric: str,
    path: str | os.PathLike[str],
    reference: float | None = None,
    title: str | None = None,
) -> None:
    """One panel per factor: each policy's level estimate ± standard error against the
    factor's values; returns are divided by `reference` (required for the return metric)."""
    if metric == RETURN and not reference:
        raise ValueError("plot_policies: field 'reference' is missing; allowed: a nonzero return")
    names = grid.names
    figure = new_figure(1, len(names), size=(3.4 * len(names), 3.4))
    for axes, name in zip(figure.axes, names, strict=True):
        values = grid.values[name]
        for policy, rows in policies.items():
            levels = {str(e["value"]): e for e in level_stats(rows, grid, metric)[name]}
            xs, ys, errors = [], [], []
            for i, value in enumerate(values):
                entry = levels.get(str(value))
                if entry is not None:
                    scale = 1.0 if metric == SUCCESS else abs(reference)
                    xs.append(i)
                    ys.append(entry["metric"] / scale)
                    errors.append(entry["stderr"] / scale)
            axes.errorbar(xs, ys, yerr=errors, marker="o", capsize=3, label=policy)
        axes.set_xticks(range(len(values)), [f"{v}" for v in values])
        axes.set_xlabel(name)
        if metric == SUCCESS:
            axes.set_ylim(-0.02, 1.02)
    if metric == RETURN:  # one scale for every panel
        lows, highs = zip(*(axes.get_ylim() for axes in figure.axes), strict=True)
        for axes in figure.axes:
            axes.set_ylim(min(lows), max(highs))
    figure.axes[0].set_ylabel(
        "success rate" if metric == SUCCESS else "mean return ÷ supervisor's at nominal"
    )
    figure.axes[0].legend(loc="best", fontsize="small")  # one legend: the policies
    if title:
        figure.suptitle(title, fontsize="medium")
    save_png_atomic(figure, path, legend_loc=None)
