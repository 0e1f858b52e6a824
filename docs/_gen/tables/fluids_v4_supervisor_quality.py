"""Renderer of docs/results/fluids_v4_supervisor_quality.json (scripts/quality/supervisor_quality.py
--env FLUIDS-v4): the ego supervisor's success, driving score and infractions per condition,
with 95 % intervals (Wilson for the success rate, bootstrap for the means)."""

from __future__ import annotations

NAMES = {
    "supervisor": "supervisor",
    "noisy": "supervisor + action noise",
    "background": "noisy controlled cars instead of the background",
}


def _ci(low: float, high: float, digits: int = 2) -> str:
    return f"[{low:.{digits}f}, {high:.{digits}f}]"


def render(data: dict, **_) -> str:
    s = data["settings"]
    infractions = next(iter(data["conditions"].values()))["infractions"]
    head = ["condition", "success", "driving score", "route completion"]
    head += [name.replace("_", " ") for name in infractions]
    lines = ["| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    for name, v in data["conditions"].items():
        cells = [
            NAMES.get(name, name),
            f"{v['success']} / {v['episodes']} {_ci(*v['success_ci'])}",
            f"{v['driving_score']:.3f} {_ci(*v['driving_score_ci'], 3)}",
            f"{v['route_completion']:.3f} {_ci(*v['route_completion_ci'], 3)}",
            *(str(c) for c in v["infractions"].values()),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    lines += [
        "",
        f"`{s['env']}`, {s['episodes']} {s['split']} seeds ({s['seeds']}); action noise "
        f"N(0, {s['noise']}²) per entry (normalised: {50 * s['noise']:g} m per waypoint "
        f"coordinate); {s['background_controlled_cars']} controlled cars with noise "
        f"N(0, {s['background_noise']}²) ({50 * s['background_noise']:g} m). Infraction columns "
        "count events over all episodes.",
    ]
    return "\n".join(lines)
