"""Renderer of docs/results/neural_vs_tree.json (scripts/baselines/neural_vs_tree.py): the MLP
and the decision tree fitted on the same BC labels, their errors on those labels and on
held-out supervisor episodes."""

from __future__ import annotations


def render(data: dict, **_) -> str:
    lines = [
        "| task | training labels | held-out labels | error | MLP: training | MLP: held out "
        "| tree: training | tree: held out | MLP epochs (best) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for row in data["rows"]:
        mlp, tree = row["mlp"], row["tree"]
        fit = mlp.get("last_fit") or {}
        lines.append(
            f"| `{row['env_id']}` | {row['training_labels']:,} | {row['heldout_labels']:,} "
            f"| {row['error']} | {mlp['train_error']:.3g} | {mlp['heldout_error']:.3g} "
            f"| {tree['train_error']:.3g} | {tree['heldout_error']:.3g} "
            f"| {fit.get('epochs_run', '–')} ({fit.get('best_epoch', '–')}) |"
        )
    return "\n".join(lines)
