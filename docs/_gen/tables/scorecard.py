"""One scorecard (`fluids-bench evaluate`): per task and set, the normalised score, return,
success and (FLUIDS) driving score, with 95 % intervals, and the seeds."""

from __future__ import annotations


def _triple(t, digits=2):
    if not t:
        return "–"
    return f"{t[0]:.{digits}f} [{t[1]:.{digits}f}, {t[2]:.{digits}f}]"


def render(card: dict) -> str:
    shortened = (
        f" Shortened evaluation: the first {card['episodes_per_set']} episodes of each set."
        if card["shortened"] and card["episodes_per_set"]
        else (" Shortened evaluation: a subset of the tasks." if card["shortened"] else "")
    )
    if card["shortened"] and not any(t["ood"] for t in card["suite"]["tasks"]):
        shortened += " The test split only (no OOD sets)."
    rows = [
        f"Policy `{card['policy']['name']}` ({card['policy']['kind']}).{shortened}",
        "",
        "| task | set | seeds | normalised score | return | random / supervisor return "
        "| success | driving score |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for task, entry in card["tasks"].items():
        for name, s in entry["sets"].items():
            seeds = s["seeds"]
            rows.append(
                f"| {task} | {name} | {seeds['first']:,} + 0..{seeds['count'] - 1} | "
                f"{_triple(s['normalised'])} | {_triple(s['return'], 1)} | "
                f"{s['random_return']:.1f} / {s['supervisor_return']:.1f} | "
                f"{_triple(s.get('success'))} | {_triple(s.get('driving_score'))} |"
            )
    for task, entry in card["tasks"].items():
        if entry.get("observation_kwargs"):  # trained with another observation of the task
            seen = ", ".join(f"`{k}={v!r}`" for k, v in sorted(entry["observation_kwargs"].items()))
            rows.append(
                f"\nOn {task} the policy observed with {seen} (what it was trained with), on the "
                "same episodes as the references."
            )
    return "\n".join(rows)
