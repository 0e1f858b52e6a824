"""Renderer of docs/results/reproduce_singulation.json (Fig. 5.3: success after 60
demonstrations per arm, and each arm's paired difference to Behavior Cloning)."""

from __future__ import annotations

import math

NAMES = {
    "bc": "BC (off-policy)",
    "dart": "DART (off-policy)",
    "dagger": "DAgger, clean supervisor labels (on-policy)",
    "dagger_retro": "DAgger, retroactive-label model (on-policy, the source's human arm)",
    "dagger_shrink_only": "ablation: DAgger, shrinkage only",
    "dagger_noise_only": "ablation: DAgger, noise only",
}


def _mean_se(values: list[float]) -> tuple[float, float]:
    n = len(values)
    mean = sum(values) / n
    if n < 2:
        return mean, 0.0
    var = sum((v - mean) ** 2 for v in values) / (n - 1)
    return mean, math.sqrt(var / n)


def render(data: dict, **options) -> str:
    summary = data["summary"]
    final = {}  # arm -> {run: success after the last demonstration}
    for r in data.get("results", []):
        final.setdefault(r["arm"], {})[r["run"]] = r["success"][-1]
    first = next(iter(summary.values()))
    shown = first["demonstrations"][-1]
    lines = [
        f"| arm ({shown} demonstrations) | runs | success | minus BC (paired, points) |",
        "|---|---|---|---|",
    ]
    shared = [s["mean"][0] for s in summary.values()]
    if len(set(shared)) == 1:
        se = first["standard_error"][0] if first["standard_error"] else 0.0
        lines.append(
            f"| after the {first['demonstrations'][0]} shared supervisor demonstrations | {first['runs']} "
            f"| {100 * shared[0]:.1f} ± {100 * se:.1f}% | |"
        )
    for arm in [a for a in NAMES if a in summary]:
        s = summary[arm]
        se = s["standard_error"][-1] if s["standard_error"] else 0.0
        diff = ""
        if arm != "bc" and "bc" in final and arm in final:
            runs = sorted(set(final[arm]) & set(final["bc"]))
            if runs:
                m, e = _mean_se([final[arm][r] - final["bc"][r] for r in runs])
                diff = f"{100 * m:+.1f} ± {100 * e:.1f}"
        lines.append(
            f"| {NAMES[arm]} | {s['runs']} | {100 * s['mean'][-1]:.1f} ± {100 * se:.1f}% | {diff} |"
        )
    settings = data["settings"]
    lines += [
        "",
        f"Success on {settings['eval_episodes']} held-out initial states per run, mean ± standard error "
        f"over runs ({data['seeds']}); learner: {settings['policy']['name']} {settings['policy']['params']}; "
        f"{data['cpu_seconds']:,.0f} CPU-s for all (run, arm) results; {data['machine']}.",
    ]
    return "\n".join(lines)
