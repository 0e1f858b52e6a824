"""docs/results/bench_compile.json (scripts/benchmarks/bench_compile.py --results): FLUIDS' cold
compile of its kernels per case, and the warm step of v1, v3 and v4."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # docs/_gen: benchfmt

from benchfmt import machine_line, n  # noqa: E402


def render(data, **_) -> str:
    out = ["| cold start (empty kernel cache) | CPU-s (user + sys) | wall s |", "|---|---|---|"]
    for case, r in data["cold_compile"].items():
        out.append(f"| {case} | {r['cpu_s']:.0f} | {r['wall_s']:.0f} |")
    warm = data.get("warm", {})
    if warm:
        out += ["", "| warm step | steps per CPU-second |", "|---|---|"]
        for env_id, r in warm.items():
            if isinstance(r, dict):
                out.append(f"| {env_id} | {n(r['steps_per_cpu_s'])} |")
        out += ["", f"FLUIDS-v3 / FLUIDS-v1: {warm['v3_vs_v1']:.2f}."]
    return "\n".join(out) + "\n\n" + machine_line(data)
