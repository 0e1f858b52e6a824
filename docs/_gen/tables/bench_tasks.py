"""docs/results/bench_{singulation,grasping}.json (scripts/benchmarks/bench_tasks.py --env ID)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # docs/_gen: benchfmt

from benchfmt import machine_line, n  # noqa: E402

MODES = {
    "supervisor": "supervisor acts (state observation)",
    "supervisor_noise": "supervisor + 10 % noise",
    "random": "random actions, label every step",
    "pixels": "supervisor acts, pixels",
}


def render(data, **_) -> str:
    out = [
        "| mode | steps/s (wall) | steps per CPU-second | replans per 100 steps | ms per replan |",
        "|---|---|---|---|---|",
    ]
    for k, r in data["results"].items():
        rp = r.get("replans_per_100_steps")
        ms = r.get("replan_ms_mean")
        out.append(
            f"| {MODES.get(k, k)} | {n(r['steps_per_s'])} | {n(r['steps_per_cpu_s'])} | "
            f"{'–' if rp is None else f'{rp:.1f}'} | {'–' if ms is None else f'{ms:.1f}'} |"
        )
    return (
        "\n".join(out)
        + f"\n\n`{data['env']}`, {data['steps']} steps per mode, a label every step. "
        + machine_line(data)
    )
