"""Renderer of docs/results/fluids_v4_dagger_ablation.json (scripts/checks/dagger_fluids_v4.py):
BC and DAgger (regression trees) on FLUIDS-v4 with the velocity planner at every step (Markov
labels) and every 5th step (the plan-carrying label), over training seeds, evaluated on
validation seeds; and how much of DAgger's own distribution follows a recovery path."""

from __future__ import annotations


def _ci(pair: list[float], digits: int = 2) -> str:
    return f"[{pair[0]:.{digits}f}, {pair[1]:.{digits}f}]"


def render(data: dict, part: str = "scores", **_) -> str:
    s = data["settings"]
    if part == "probe":
        lines = [
            "| planner period | DAgger's states | on a recovery path | of those, label more than "
            f"{s['recovery_tolerance_m']} m from a re-planned one |",
            "|---|---|---|---|",
        ]
        for period, algos in data["results"].items():
            p = algos["dagger"]["probe"]
            lines.append(
                f"| {period} | {p['states']:,} | {p['recovering']:,} "
                f"({100 * p['recovering'] / p['states']:.0f} %) | "
                f"{p['label_differs_from_replanned']:,} |"
            )
        return "\n".join(lines)
    lines = [
        "| planner period | learner | success | per training seed | driving score | "
        "per training seed | labels per seed |",
        "|---|---|---|---|---|---|---|",
    ]
    for period, algos in data["results"].items():
        for algo, v in algos.items():
            lines.append(
                f"| {period} | {'BC' if algo == 'bc' else 'DAgger'} | "
                f"{v['success_rate']:.2f} {_ci(v['success_ci'])} | "
                + ", ".join(f"{x:.2f}" for x in v["success_per_seed"])
                + f" | {v['driving_score']:.3f} {_ci(v['driving_score_ci'], 3)} | "
                + ", ".join(f"{x:.2f}" for x in v["driving_score_per_seed"])
                + " | "
                + ", ".join(f"{x:,}" for x in v["labels_per_seed"])
                + " |"
            )
    first, last = s["validation_seeds"]
    lines += [
        "",
        f"Regression trees, {s['iterations']} rollouts per run (DAgger: 1 supervisor "
        f"demonstration, then its learner with beta = 0), every state kept; each run's learner "
        f"on {s['episodes']} validation seeds ({first}–{last}), pooled over training seeds: "
        "success with its Wilson interval, driving score with its bootstrap interval.",
    ]
    return "\n".join(lines)
