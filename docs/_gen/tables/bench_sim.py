"""docs/results/bench_sim.json (scripts/benchmarks/bench_sim.py --results): FLUIDS simulator speed."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # docs/_gen: benchfmt

from benchfmt import machine_line, n  # noqa: E402

NAMES = {
    "S1": "S1: four-way, 4 cars + 2 pedestrians, no observation",
    "S2": "S2: `FLUIDS-v0`, ego + 10 cars + 5 pedestrians, explicit observation + label",
    "S2v1": "S2 as `FLUIDS-v1` (its defensive planner and rules)",
    "S3": "S3: two-lane four-way, 20 cars + 10 pedestrians, no observation",
}


def render(data, **_) -> str:
    out = [
        "| scenario | steps/s (wall) | steps per CPU-second | episodes (resets timed) |",
        "|---|---|---|---|",
    ]
    for k, r in data["results"].items():
        out.append(
            f"| {NAMES.get(k, k)} | {n(r['steps_per_s'])} | {n(r['steps_per_cpu_s'])} | "
            f"{r['episodes']} |"
        )
    return "\n".join(out) + f"\n\n{data['steps']} steps per scenario. " + machine_line(data)
