"""docs/results/bench_sensors.json (scripts/benchmarks/bench_sensors.py --results): S2 with each
sensor (`part="env"`) and the cost of one sensor call (`part="calls"`)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # docs/_gen: benchfmt

from benchfmt import machine_line, n  # noqa: E402


def render(data, part: str = "env", **_) -> str:
    res = data["results"]
    if part == "calls":
        out = ["| sensor call | median (µs, wall) | median (µs, CPU) |", "|---|---|---|"]
        for k, r in res["sensor_cost"].items():
            out.append(f"| {k} | {r['median_us']:.0f} | {r['median_cpu_us']:.0f} |")
        return "\n".join(out) + f"\n\n{data['calls']} calls per sensor. " + machine_line(data)
    out = ["| S2 variant | steps/s (wall) | steps per CPU-second |", "|---|---|---|"]
    for k, r in res["env_steps"].items():
        out.append(f"| {k} | {n(r['steps_per_s'])} | {n(r['steps_per_cpu_s'])} |")
    return "\n".join(out) + f"\n\n{data['steps']} steps per variant. " + machine_line(data)
