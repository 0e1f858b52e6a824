"""Plots of scorecards: per-task bars with 95 % intervals, and label-efficiency curves."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(figure: Any, path: str | os.PathLike[str]) -> None:
    """Write the PNG atomically (a temporary file, then a rename)."""
    path = os.fspath(path)
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    tmp = f"{path}.tmp-{os.getpid()}.png"
    figure.savefig(tmp, dpi=110, bbox_inches="tight")
    os.replace(tmp, path)


def _bars(axes: Any, cards: Sequence[dict[str, Any]], split: str) -> None:
    tasks = list(dict.fromkeys(t for card in cards for t in card["tasks"]))
    labels = [*tasks, "mean", "IQM"]
    width = 0.8 / max(len(cards), 1)
    for i, card in enumerate(cards):
        values, lows, highs = [], [], []
        for task in tasks:
            sets = card["tasks"].get(task, {}).get("sets", {})
            chosen = [s for n, s in sets.items() if (n == "test") == (split == "test")]
            triples = [s["normalised"] for s in chosen if s.get("normalised")]
            if triples:  # OOD: the mean over the task's OOD sets, its interval's ends averaged
                point, low, high = np.mean(np.asarray(triples), axis=0)
            else:
                point = low = high = np.nan
            values.append(point)
            lows.append(point - low)
            highs.append(high - point)
        aggregate = (card.get("aggregate") or {}).get(split) or {}
        for key in ("mean", "iqm"):
            point, low, high = aggregate.get(key, [np.nan] * 3)
            values.append(point)
            lows.append(point - low)
            highs.append(high - point)
        x = np.arange(len(labels)) + (i - (len(cards) - 1) / 2) * width
        axes.bar(x, values, width, yerr=[lows, highs], capsize=2, label=card_label(card))
    axes.set_xticks(range(len(labels)), labels, rotation=30, ha="right")
    axes.axhline(0.0, color="0.5", lw=0.8)
    axes.axhline(1.0, color="0.5", lw=0.8, ls="--")
    shortened = any(card.get("shortened") for card in cards)
    title = "test split" if split == "test" else "out-of-distribution sets (mean per task)"
    axes.set_title(title + (" (shortened evaluation)" if shortened else ""))
    axes.set_ylabel("normalised score (0 random, 1 supervisor)")


def plot_scorecard(card: dict[str, Any], path: str | os.PathLike[str]) -> None:
    """Per-task normalised scores with their 95 % intervals, test and OOD, plus the suite's
    mean and IQM; and the label-efficiency curve when the scorecard has one."""
    plot_scorecards([card], path)


def plot_scorecards(cards: Sequence[dict[str, Any]], path: str | os.PathLike[str]) -> None:
    """Several policies' scorecards side by side (the leaderboard's figure)."""
    plt = _pyplot()
    curves = [c for c in cards if c.get("label_efficiency")]
    panels = 2 + (1 if curves else 0)
    figure, axes = plt.subplots(1, panels, figsize=(6 * panels, 4.2))
    _bars(axes[0], cards, "test")
    _bars(axes[1], cards, "ood")
    axes[0].legend(fontsize="small")
    if curves:
        plot_label_efficiency_axes(axes[2], curves)
    _save(figure, path)
    plt.close(figure)


def card_label(card: dict[str, Any]) -> str:
    """A scorecard's legend entry: its policy, how many tasks, episodes per set (`all` for the
    full sets) and `test only` when it has no OOD set."""
    episodes = card.get("episodes_per_set") or "all"
    test_only = not any(t["ood"] for t in card["suite"]["tasks"])
    return f"{card['policy']['name']} ({len(card['tasks'])} tasks, {episodes} ep/set" + (
        ", test only)" if test_only else ")"
    )


def plot_label_efficiency_axes(axes: Any, cards: Sequence[dict[str, Any]]) -> None:
    for card in cards:
        for task, curve in card["label_efficiency"].items():
            axes.plot(
                curve["labels"], curve["scores"], marker="o",
                label=f"{card_label(card)}, {task} (area {curve['area']:.2f})",
            )  # fmt: skip
    axes.set_xlabel("supervisor labels used")
    axes.set_ylabel("normalised score (train run's evaluation seeds)")
    axes.set_title("label efficiency")
    axes.legend(fontsize="small")
