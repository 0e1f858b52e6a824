"""Learning-curve PNGs, drawn with matplotlib's Agg canvas (no pyplot, no display needed)."""

from __future__ import annotations

import io
import os
from collections.abc import Sequence

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from fluids_bench.algos.results import RunResult, write_bytes_atomic
from fluids_bench.core.validation import check_choice


def new_figure(rows: int = 1, cols: int = 1, size: tuple[float, float] = (6.0, 4.0)) -> Figure:
    """A figure with its own Agg canvas (thread- and backend-independent)."""
    figure = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(figure)
    figure.subplots(rows, cols, squeeze=False)
    return figure


def save_png_atomic(
    figure: Figure, path: str | os.PathLike[str], legend_loc: str | None = "best"
) -> None:
    """Add a light grid and a small legend (unless `legend_loc` is None) to every axes,
    render `figure` to PNG in memory, then write it atomically."""
    for axes in figure.axes:
        axes.grid(alpha=0.3)
        if legend_loc is not None:
            axes.legend(loc=legend_loc, fontsize="small")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=120)
    write_bytes_atomic(path, buffer.getvalue())


# x-axis choices: the source plots trajectory-level experiments against demonstrations and
# state-level ones against the labelled examples used for training
X_AXES = {
    "training_labels": "state–label pairs used for training",
    "demonstrations": "demonstrations",
    "labels_requested": "supervisor labels requested (training + noise estimation)",
}


def learning_curve_figure(results: Sequence[RunResult], x: str = "training_labels") -> Figure:
    """Normalised performance (± standard error) of the learned policy, its success rate when
    the env reports success, and the return while collecting (the layout of the source's
    Fig. 3.3), all against `x` (a key of `X_AXES`)."""
    check_choice("learning_curve_figure", "x", x, X_AXES)
    with_success = any(r.eval_success_rate is not None for res in results for r in res.records)
    figure = new_figure(3 if with_success else 2, 1, (6.5, 9.0 if with_success else 6.5))
    top, *middle, bottom = figure.axes
    for result in results:
        evaluated = [r for r in result.evaluated() if r.normalised_performance is not None]
        span = result.supervisor_return - result.config.get("return_floor", 0.0)
        errors = [(r.eval_return_se or 0.0) / span if span > 0 else 0.0 for r in evaluated]
        top.errorbar(
            [getattr(r, x) for r in evaluated],
            [r.normalised_performance for r in evaluated],
            yerr=errors,
            marker="o",
            capsize=3,
            label=result.algo,
        )
        if middle:
            scored = [r for r in result.evaluated() if r.eval_success_rate is not None]
            middle[0].errorbar(
                [getattr(r, x) for r in scored],
                [r.eval_success_rate for r in scored],
                yerr=[r.eval_success_se or 0.0 for r in scored],
                marker="o",
                capsize=3,
                label=result.algo,
            )
        bottom.plot(
            [getattr(r, x) for r in result.records],
            [r.collection_return for r in result.records],
            marker=".",
            label=result.algo,
        )
    if results:
        policy = results[0].config["policy"]
        # a scikit-learn family by name, a user's learner by its own name (first word)
        learner = policy["name"] if "name" in policy else policy["learner"].split()[0]
        bottom.axhline(results[0].supervisor_return, color="black", ls="--", label="supervisor")
        episodes = results[0].config.get("eval_episodes")
        top.set_title(
            f"{results[0].config['env_id']}, policy {learner}, "
            f"{episodes} evaluation episodes (bars: standard error)"
        )
        rate = results[0].supervisor_metrics.get("success_rate")
        if middle and rate is not None:
            middle[0].axhline(rate, color="black", ls="--", label="supervisor")
    top.axhline(1.0, color="black", ls="--", lw=1)
    top.set_ylabel("normalised performance")
    if middle:
        middle[0].set_ylabel("success rate")
    bottom.set_ylabel("return during collection")
    bottom.set_xlabel(X_AXES[x])
    return figure


def plot_learning_curves(
    results: Sequence[RunResult], path: str | os.PathLike[str], x: str = "training_labels"
) -> None:
    """`learning_curve_figure` written to `path` as PNG."""
    save_png_atomic(learning_curve_figure(results, x), path)
