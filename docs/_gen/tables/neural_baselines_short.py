"""Renderer of docs/results/neural_baselines*.json (scripts/baselines/neural_baselines.py):
per setup, algorithm and learner, the normalised performance (the harness's), the success rate
where one is recorded, the labels trained on and the training time, over the run's seeds."""

from __future__ import annotations


def render(data: dict, **_) -> str:
    with_success = any(r["success_rate"] is not None for r in data["summary"])
    head = ["setup", "algorithm", "learner", "seeds", "normalised performance"]
    head += ["success rate"] * with_success + ["training labels", "train s"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in data["summary"]:
        cells = [r["setup"], r["algo"], r["learner"], r["seeds"]]
        perf = r["normalised_performance"]
        cells.append("–" if perf is None else f"{perf:.3f}")
        if with_success:
            s = r["success_rate"]
            cells.append("–" if s is None else f"{s:.2f}")
        cells += [r["training_labels"], f"{r['train_seconds']:.2f}"]
        lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    ids = {}
    for row in data.get("rows", []):
        ids.setdefault(row["setup"], row["env_id"])
    notes = [f"budget `{data['budget']}`"]
    notes += [f"{setup}: `{env_id}`" for setup, env_id in ids.items()]
    if data.get("machine"):
        notes.append(f"machine: {data['machine']}")
    return "\n".join(lines) + "\n\n" + "; ".join(notes) + "."
