"""Plots and the summary of a sweep.

The sensitivity plot (the source's Fig. 7.6): the metric against each normalised parameter. For
every parameter and each of its values, the metric over all episodes of all configurations with
that value (the marginal over the other parameters); the x axis maps each parameter's grid range
to [0, 1], one line per parameter.

The metric is the success rate (`info["is_success"]`) on the FLUIDS-Sensitivity grid and on
any env that reports success (FLUIDS on an episode's terminating step, the others on every step); elsewhere (MuJoCo locomotion, GridWorld, DAG) the normalised
return: a configuration's mean return divided by the largest absolute mean return over the
sweep's configurations (1 = the best configuration). A kwarg grid also gets heatmaps for every
pair of factors and a summary table (Markdown and JSON) with standard errors.
"""

from __future__ import annotations

import itertools
import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from fluids_bench.algos.plots import new_figure, save_png_atomic
from fluids_bench.algos.results import write_bytes_atomic, write_json_atomic

SUCCESS, RETURN = "success", "return"
# the env metadata key of envs that put info["is_success"] on the terminating step only (a probe
# of the first step cannot see it, and running an episode to its end costs too much on some tasks)
SUCCESS_ON_TERMINATION = "success_on_termination"


def reports_success(env_id: str, kwargs: Mapping[str, Any] | None = None) -> bool:
    """Whether `env_id` reports `info["is_success"]`: its env class says so in its metadata
    (`SUCCESS_ON_TERMINATION`), or the key is there after a reset or one labelled step."""
    import gymnasium as gym
    from gymnasium.envs.registration import load_env_creator

    import fluids_bench  # noqa: F401

    entry_point = gym.spec(env_id).entry_point
    creator = load_env_creator(entry_point) if isinstance(entry_point, str) else entry_point
    if getattr(creator, "metadata", {}).get(SUCCESS_ON_TERMINATION, False):
        return True
    env = gym.make(env_id, **dict(kwargs or {}))
    try:
        _, info = env.reset(seed=0)
        if "is_success" in info:
            return True
        action = info.get("supervisor_action", env.action_space.sample())
        return "is_success" in env.step(action)[4]
    finally:
        env.close()


def _values(rows: Sequence[Mapping[str, Any]], metric: str) -> list[float]:
    """Each row's metric (success rate, or mean return / max |mean return|)."""
    if metric == SUCCESS:
        return [int(r["successes"]) / int(r["episodes"]) for r in rows]
    scale = max((abs(float(r["mean_return"])) for r in rows), default=0.0) or 1.0
    return [float(r["mean_return"]) / scale for r in rows]


def row_matches(row: Mapping[str, Any], name: str, value: Any) -> bool:
    """Whether result row `row` has `value` for parameter `name`."""
    if isinstance(value, str):
        return row[name] == value
    return float(row[name]) == float(value)


def marginals(
    rows: Sequence[Mapping[str, Any]], grid: Any, metric: str = SUCCESS
) -> dict[str, list[tuple[float, float]]]:
    """`{parameter: [(normalised value, metric), ...]}` over the rows given. Success rates
    pool episodes; normalised returns average configurations (equal episodes each)."""
    out: dict[str, list[tuple[float, float]]] = {}
    per_row = _values(rows, metric)
    for name in grid.names:
        points = []
        for value in grid.values[name]:
            chosen = [i for i, r in enumerate(rows) if row_matches(r, name, value)]
            episodes = sum(int(rows[i]["episodes"]) for i in chosen)
            if episodes:
                if metric == SUCCESS:
                    level = sum(int(rows[i]["successes"]) for i in chosen) / episodes
                else:
                    level = sum(per_row[i] for i in chosen) / len(chosen)
                points.append((grid.normalise(name, value), level))
        out[name] = points
    return out


def _label(name: str, grid: Any) -> str:
    values = grid.values[name]
    kind = grid.kinds[name]
    if kind == "bool":
        return f"{name.replace('_', ' ')} (off→on)"
    if kind == "str":
        return f"{name.replace('_', ' ')} ({values[0]}→{values[-1]})"
    unit = " kg" if name == "car_mass" else ""
    return f"{name.replace('_', ' ')} ({values[0]:g}–{values[-1]:g}{unit})"


def _ylabel(metric: str, legacy: bool) -> str:
    if metric == SUCCESS:
        return "success rate (every car reaches its goal)" if legacy else "success rate"
    return "mean return / best configuration's"


def plot_sensitivity(
    rows: Sequence[Mapping[str, Any]],
    grid: Any,
    path: str | os.PathLike[str],
    title: str | None = None,
    metric: str = SUCCESS,
) -> None:
    """Write the PNG (atomically) for the rows finished so far."""
    figure = new_figure(size=(7.0, 4.5))
    (axes,) = figure.axes
    drawn = False
    for name, points in marginals(rows, grid, metric).items():
        if points:
            drawn = True
            xs, ys = zip(*points, strict=True)
            axes.plot(xs, ys, marker="o", label=_label(name, grid))
    episodes = sum(int(r["episodes"]) for r in rows)
    axes.set_xlabel("normalised parameter value")
    axes.set_ylabel(_ylabel(metric, grid.legacy))
    axes.set_xlim(-0.03, 1.03)
    if metric == SUCCESS:
        axes.set_ylim(-0.02, 1.02)
    axes.set_title(
        title
        or f"Sensitivity of the learned policy: {len(rows)} of {len(grid)} "
        f"configurations, {episodes} episodes",
        fontsize="medium",
    )
    save_png_atomic(figure, path, legend_loc="best" if drawn else None)


def pair_table(
    rows: Sequence[Mapping[str, Any]], grid: Any, a: str, b: str, metric: str
) -> list[list[float]]:
    """The metric for every (value of a, value of b), averaged over the other factors (NaN
    where no row is finished)."""
    per_row = _values(rows, metric)
    table = []
    for va in grid.values[a]:
        line = []
        for vb in grid.values[b]:
            chosen = [
                i for i, r in enumerate(rows) if row_matches(r, a, va) and row_matches(r, b, vb)
            ]
            line.append(sum(per_row[i] for i in chosen) / len(chosen) if chosen else math.nan)
        table.append(line)
    return table


def plot_heatmaps(
    rows: Sequence[Mapping[str, Any]], grid: Any, path: str | os.PathLike[str], metric: str
) -> bool:
    """One heatmap per pair of factors (False, and nothing written, with fewer than two)."""
    pairs = list(itertools.combinations(grid.names, 2))
    if not pairs:
        return False
    cols = min(3, len(pairs))
    nrows = math.ceil(len(pairs) / cols)
    figure = new_figure(nrows, cols, size=(4.2 * cols, 3.6 * nrows))
    axes_list = figure.axes
    for axes, (a, b) in zip(axes_list, pairs, strict=False):
        table = pair_table(rows, grid, a, b, metric)
        lo, hi = (0.0, 1.0) if metric == SUCCESS else (None, None)
        image = axes.imshow(table, origin="lower", aspect="auto", vmin=lo, vmax=hi, cmap="viridis")
        axes.set_xticks(range(len(grid.values[b])), [f"{v}" for v in grid.values[b]])
        axes.set_yticks(range(len(grid.values[a])), [f"{v}" for v in grid.values[a]])
        axes.set_xlabel(b)
        axes.set_ylabel(a)
        for i, line in enumerate(table):
            for j, value in enumerate(line):
                if not math.isnan(value):
                    axes.text(j, i, f"{value:.2f}", ha="center", va="center", color="w")
        figure.colorbar(image, ax=axes, shrink=0.8)
    for axes in axes_list[len(pairs) :]:
        axes.set_visible(False)
    save_png_atomic(figure, path, legend_loc=None)
    return True


def summary(rows: Sequence[Mapping[str, Any]], grid: Any, metric: str) -> dict[str, Any]:
    """Per factor and level: episodes, the metric, its standard error, and (where the env
    reports success) the success rate; plus the overall figures."""
    per_row = _values(rows, metric)
    factors: dict[str, list[dict[str, Any]]] = {}
    for name in grid.names:
        levels = []
        for value in grid.values[name]:
            chosen = [i for i, r in enumerate(rows) if row_matches(r, name, value)]
            if not chosen:
                continue
            episodes = sum(int(rows[i]["episodes"]) for i in chosen)
            successes = sum(int(rows[i]["successes"]) for i in chosen)
            entry: dict[str, Any] = {"value": value, "configurations": len(chosen)}
            entry["episodes"] = episodes
            if metric == SUCCESS:
                p = successes / episodes
                entry["metric"] = p
                entry["stderr"] = math.sqrt(p * (1 - p) / episodes)
            else:
                values = [per_row[i] for i in chosen]
                mean = sum(values) / len(values)
                var = sum((v - mean) ** 2 for v in values) / max(len(values) - 1, 1)
                entry["metric"] = mean
                entry["stderr"] = math.sqrt(var / len(values))  # over configurations
                entry["mean_return"] = sum(float(rows[i]["mean_return"]) for i in chosen) / len(
                    chosen
                )
            levels.append(entry)
        factors[name] = levels
    episodes = sum(int(r["episodes"]) for r in rows)
    return {
        "metric": metric,
        "configurations": len(rows),
        "episodes": episodes,
        "overall": sum(per_row) / len(per_row) if per_row else math.nan,
        "factors": factors,
    }


def summary_markdown(data: Mapping[str, Any]) -> str:
    name = "success rate" if data["metric"] == SUCCESS else "normalised return"
    lines = [
        f"{data['configurations']} configurations, {data['episodes']} episodes; "
        f"overall {name} {data['overall']:.3f}",
        "",
        f"| factor | value | configurations | episodes | {name} | s.e. |",
        "|---|---|---|---|---|---|",
    ]
    for factor, levels in data["factors"].items():
        for e in levels:
            lines.append(
                f"| {factor} | {e['value']} | {e['configurations']} | {e['episodes']} | "
                f"{e['metric']:.3f} | {e['stderr']:.3f} |"
            )
    return "\n".join(lines) + "\n"


def write_kwarg_outputs(
    rows: Sequence[Mapping[str, Any]], grid: Any, folder: str | os.PathLike[str], env_id: str
) -> list[Path]:
    """heatmaps.png, summary.json and summary.md for a kwarg grid's rows."""
    folder = Path(folder)
    metric = metric_for(folder, env_id)
    written = []
    if plot_heatmaps(rows, grid, folder / "heatmaps.png", metric):
        written.append(folder / "heatmaps.png")
    data = summary(rows, grid, metric)
    write_json_atomic(folder / "summary.json", json.loads(json.dumps(data)))
    write_bytes_atomic(folder / "summary.md", summary_markdown(data).encode())
    return [*written, folder / "summary.json", folder / "summary.md"]


def metric_for(folder: str | os.PathLike[str], env_id: str) -> str:
    """The metric of a sweep folder: success where its env reports it, else the return."""
    from fluids_bench.sweep.store import ResultStore

    manifest = ResultStore(folder).read_manifest() or {}
    if manifest.get("format", 1) == 1:
        return SUCCESS
    return SUCCESS if reports_success(env_id, manifest.get("env_kwargs")) else RETURN
