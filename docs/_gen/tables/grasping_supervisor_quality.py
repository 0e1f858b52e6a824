"""Renderer of docs/results/grasping_supervisor_quality.json (the grasping supervisor's success
and cost with and without noise injected into the executed action)."""

from __future__ import annotations


def render(data: dict, **options) -> str:
    lines = [
        "| executed action | episodes | success | mean cost | grasped | knocked off / episode "
        "| steps | replans / episode |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for key, r in sorted(data["results"].items(), key=lambda kv: float(kv[0])):
        noise = float(key)
        name = "supervisor" if noise == 0 else f"supervisor + N(0, {noise:g}²) noise"
        lines.append(
            f"| {name} | {r['episodes']} | {100 * r['success_rate']:.1f}% ± {100 * r['success_stderr']:.1f}% "
            f"| {r['mean_cost']:.2f} ± {r['cost_stderr']:.2f} | {100 * r['grasp_rate']:.1f}% "
            f"| {r['mean_knocked_off']:.2f} | {r['mean_steps']:.1f} | {r['mean_replans']:.2f} |"
        )
    failed = data["results"][min(data["results"], key=float)]["failed_seeds"]
    lines += [
        "",
        f"Seeds {data['seeds']}, horizon {data['horizon_steps']} steps; ± standard error; noise: "
        f"{data['noise']}; cost = knocked off + 10 × (not grasped); {data['machine']}. "
        f"Failed seeds without noise: {', '.join(map(str, failed)) or 'none'}.",
    ]
    return "\n".join(lines)
