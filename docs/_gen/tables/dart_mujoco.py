"""Renderer of docs/results/dart_mujoco_*.json (Fig. 3.3 and 3.4, every task and setting).

The DART-on-MuJoCo files share one layout (written by scripts/reproductions/reproduce_dart_mujoco.py),
so the other dart_mujoco_* renderers reuse this one's ``render``.
"""

from __future__ import annotations

METHODS = {
    "bc": "BC",
    "dagger": "DAgger",
    "dagger_b": "DAgger-B",
    "isotropic": "isotropic Σ = I",
    "dart": "DART",
    "dart_fixed": "DART, Σ̂ rescaled to trace {trace:g} (ablation)",
}
LEARNERS = ("mlp", "linear")


def _n(x: float) -> str:
    return f"{x:,.0f}"


def render(data: dict, **options) -> str:
    settings = data["settings"]
    summary = data["summary"]
    rows = []
    for key, s in summary.items():
        _, learner, method = key.split("/")
        rows.append((LEARNERS.index(learner), list(METHODS).index(method), learner, method, s))
    rows.sort()
    eval_at = rows[0][4]["eval_iterations"]
    head = "| learner / method | " + " | ".join(f"iter {i}" for i in eval_at)
    head += " | mean collection return | fit seconds |"
    lines = [head, "|---|" + "---|" * (len(eval_at) + 2)]
    for _, _, learner, method, s in rows:
        name = METHODS[method].format(trace=settings.get("dart_fixed_trace", 0.0))
        cells = [
            f"{_n(m)} ± {_n(e)}"
            for m, e in zip(s["eval_return_mean"], s["eval_return_se"], strict=True)
        ]
        collection = sum(s["collection_return_mean"]) / len(s["collection_return_mean"])
        lines.append(
            f"| {'MLP' if learner == 'mlp' else 'linear'} / {name} | "
            + " | ".join(cells)
            + f" | {_n(collection)} | {s['train_seconds_total_mean']:.0f} |"
        )
    first = rows[0][4]
    lines.append("")
    lines.append(
        f"Mean evaluation return ± standard error over {first['seeds']} seeds "
        f"({settings['eval_episodes']} seeded episodes of {settings['eval_steps']} steps per point); "
        f"the supervisor scores {_n(first['supervisor_return_mean'])} over {settings['eval_steps']} steps. "
        "Mean collection return: the reward of the rollouts each method collected, over all iterations. "
        "Fit seconds: total time fitting the learner (cumulative `train_seconds`, mean over seeds)."
    )
    return "\n".join(lines)
