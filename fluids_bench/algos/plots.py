"""Learning-curve PNGs, drawn with matplotlib's Agg canvas (no pyplot, no display needed)."""

from __future__ import annotations

import io
import os
from collections.abc import Sequence

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from fluids_bench.algos.results import RunResult, write_bytes_atomic


def new_figure(rows: int = 1, cols: int = 1, size: tuple[float, float] = (6.0, 4.0)) -> Figure:
    """A figure with its own Agg canvas (thread- and backend-independent)."""
    figure = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(figure)
    figure.subplots(rows, cols, squeeze=False)
    return figure


def save_png_atomic(
    figure: Figure, path: str | os.PathLike[str], legend_loc: str | None = "best"
) -> None:
    """Add a light grid and a small legend (unless ``legend_loc`` is None) to every axes,
    render ``figure`` to PNG in memory, then write it atomically."""
    for axes in figure.axes:
        axes.grid(alpha=0.3)
        if legend_loc is not None:
            axes.legend(loc=legend_loc, fontsize="small")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=120)
    write_bytes_atomic(path, buffer.getvalue())


def plot_learning_curves(results: Sequence[RunResult], path: str | os.PathLike[str]) -> None:
    """Top: normalised performance of the learned policy; bottom: return while collecting.

    Both against the supervisor labels requested (the layout of the source's Fig. 3.3).
    """
    figure = new_figure(2, 1, (6.5, 6.5))
    top, bottom = figure.axes
    for result in results:
        evaluated = [r for r in result.evaluated() if r.normalised_performance is not None]
        top.plot(
            [r.labels_requested for r in evaluated],
            [r.normalised_performance for r in evaluated],
            marker="o",
            label=result.algo,
        )
        bottom.plot(
            [r.labels_requested for r in result.records],
            [r.collection_return for r in result.records],
            marker=".",
            label=result.algo,
        )
    if results:
        bottom.axhline(results[0].supervisor_return, color="black", ls="--", label="supervisor")
        top.set_title(
            f"{results[0].config['env_id']}, policy {results[0].config['policy']['name']}"
        )
    top.axhline(1.0, color="black", ls="--", lw=1)
    top.set_ylabel("normalised performance")
    bottom.set_ylabel("return during collection")
    bottom.set_xlabel("supervisor labels requested")
    save_png_atomic(figure, path)
