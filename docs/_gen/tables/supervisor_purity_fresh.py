"""Renderer of docs/results/supervisor_purity_fresh.json (scripts/checks/supervisor_purity.py
--copy fresh): per id, the states at which a supervisor built afresh from the restored state
disagrees with the driving env's label, under random actions and a noisy supervisor."""

from __future__ import annotations


def _cell(v: dict) -> str:
    return f"{v['label']} / {v['states']}"


def render(data: dict, **_) -> str:
    lines = [
        "| id | random: labels that differ | noisy supervisor | supervisor rebuilt |",
        "|---|---|---|---|",
    ]
    for env_id, drivers in data["results"].items():
        fresh = "yes" if all(d["fresh"] for d in drivers.values()) else "no (no memory to drop)"
        lines.append(
            f"| `{env_id}` | {_cell(drivers['random'])} | {_cell(drivers['noisy'])} | {fresh} |"
        )
    return "\n".join(lines)
