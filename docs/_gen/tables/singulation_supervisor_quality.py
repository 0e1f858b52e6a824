"""Renderer of docs/results/singulation_supervisor_quality.json (the Singulation supervisor's
success with and without noise injected into the executed action)."""

from __future__ import annotations


def render(data: dict, **options) -> str:
    lines = [
        "| action noise (std) | episodes | success | 95% interval | steps to success | replans / episode |",
        "|---|---|---|---|---|---|",
    ]
    for r in data["table"]:
        lo, hi = r["wilson95"]
        steps = "–" if r["mean_steps_to_success"] is None else f"{r['mean_steps_to_success']:.1f}"
        lines.append(
            f"| {r['noise_std']:.2f} | {r['episodes']} | {100 * r['success_rate']:.1f}% "
            f"| {100 * lo:.1f}–{100 * hi:.1f}% | {steps} | {r['replans_per_episode']:g} |"
        )
    lines += [
        "",
        f"Seeds {data['seeds']}, horizon {data['horizon']} steps; noise: {data['noise']}; "
        f"95% Wilson interval; {data['machine']}.",
    ]
    return "\n".join(lines)
