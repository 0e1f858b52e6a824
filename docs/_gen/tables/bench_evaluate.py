"""docs/results/bench_evaluate.json (scripts/benchmarks/bench_evaluate.py --results): the same
FLUIDS-v4 test episodes of random and of the supervisor, one by one (scalar env) and B at a time
(vector env), CPU seconds of each and whether the rows agree."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # docs/_gen: benchfmt

from benchfmt import machine_line, n  # noqa: E402


def render(data, **_) -> str:
    out = [
        f"{data['episodes']} `{data['env_id']}` test episodes per policy (seeds "
        f"{data['seeds']['first']} on).",
        "",
        "| policy | path | CPU-s | env-steps per CPU-s | CPU-s, scalar / this | same rows |",
        "|---|---|---|---|---|---|",
    ]
    for policy, r in data["policies"].items():
        s = r["scalar"]
        out.append(
            f"| {policy} | one by one | {s['cpu_s']:.1f} | {n(s['steps_per_cpu_s'])} | 1 | |"
        )
        for batch, v in r["vector"].items():
            same = "yes" if v["rows_equal"] else "**no**"
            out.append(
                f"| {policy} | B = {batch} | {v['cpu_s']:.1f} | {n(v['steps_per_cpu_s'])} | "
                f"{v['cpu_speedup']:.2f} | {same} |"
            )
    return "\n".join(out) + "\n\n" + machine_line(data)
