"""Renderer of docs/results/singulation_markov.json (scripts/checks/singulation_markov.py):
Singulation-v0's supervisor with its cached plan against one built afresh at every step."""

from __future__ import annotations

NAMES = {"cached_plan": "cached plan (shipped)", "markov": "built afresh every step"}


def render(data: dict, **_) -> str:
    first, last = data["seeds"]
    n = last - first + 1
    lines = ["| supervisor | singulated | mean steps | ms per label |", "|---|---|---|---|"]
    for name, v in data["results"].items():
        lines.append(
            f"| {NAMES.get(name, name)} | {round(v['success'] * n)} / {n} "
            f"| {v['mean_steps']:.0f} | {v['ms_per_label']:.2f} |"
        )
    return "\n".join(lines) + f"\n\n`{data['env_id']}`, seeds {first}–{last}."
