"""Renderer of docs/results/fluids_v4_planner_period.json (scripts/benchmarks/bench_planner_period.py):
FLUIDS-v4's step time under supervisor labels with the velocity planner every step or every 5th."""

from __future__ import annotations


def render(data: dict, **_) -> str:
    lines = ["| planner period | steps | CPU s | ms per step |", "|---|---|---|---|"]
    for period, v in data["periods"].items():
        lines.append(f"| {period} | {v['steps']} | {v['cpu_s']:.2f} | {v['ms_per_step']:.2f} |")
    seeds = data["seeds"]
    machine = data.get("machine", {})
    notes = [
        f"`{data['env_id']}`, {data['episodes']} episodes per period (seeds {seeds[0]}–{seeds[1]}),"
        " interleaved",
        f"period 1 / period 5 = **{data['cost_1_over_5']:.2f}×** the step time",
    ]
    if machine:
        notes.append(f"{machine.get('cpu_model')} × {machine.get('cpu_count')} (shared)")
    return "\n".join(lines) + "\n\n" + "; ".join(notes) + "."
