"""Renderer of docs/results/reproduce_gridworld.json (Fig. 3.1: BC vs DAgger on random
gridworlds, linear SVM and depth-100 tree)."""

from __future__ import annotations

NAMES = {
    "linear_svm/off_policy_bc": "linear SVM, BC (off-policy)",
    "linear_svm/on_policy_dagger": "linear SVM, DAgger (on-policy)",
    "tree_depth_100/off_policy_bc": "tree (depth 100), BC (off-policy)",
    "tree_depth_100/on_policy_dagger": "tree (depth 100), DAgger (on-policy)",
}


def render(data: dict, columns: tuple[int, ...] = (1, 5, 11, 21), **options) -> str:
    summary = data["summary"]
    demos = next(iter(summary.values()))["demonstrations"]
    shown = [d for d in columns if d in demos]
    lines = [
        "| demonstrations (state–label pairs) | "
        + " | ".join(f"{d} ({30 * d})" for d in shown)
        + " |",
        "|---|" + "---|" * len(shown),
    ]
    for key, name in NAMES.items():
        curve = summary[key]
        cells = []
        for d in shown:
            i = curve["demonstrations"].index(d)
            se = curve["standard_error"][i] if curve["standard_error"] else 0.0
            cells.append(f"{curve['mean'][i]:.3f} ± {se:.3f}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    worlds = {c["worlds_used"] for c in summary.values()}
    s = data["settings"]
    lines += [
        "",
        f"Mean normalised performance ± standard error over {', '.join(map(str, sorted(worlds)))} worlds "
        f"({data['seeds']}; {s['eval_episodes']} evaluation episodes per point; 1.0 = the supervisor on "
        f"the same seeds); {data['seconds']:.0f} s wall with {data['workers']} worker(s) on {data['machine']}.",
    ]
    return "\n".join(lines)
