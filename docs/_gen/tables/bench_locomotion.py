"""docs/results/bench_locomotion.json (scripts/benchmarks/bench_locomotion.py --results): the
labelled IL envs next to Gymnasium's bare v5 envs, interleaved blocks, best of each."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # docs/_gen: benchfmt

from benchfmt import machine_line, n  # noqa: E402


def render(data, **_) -> str:
    out = [
        "| env | supervisor | bare `*-v5` steps/s | labelled steps/s | label overhead |",
        "|---|---|---|---|---|",
    ]
    for r in data["results"]:
        out.append(
            f"| `{r['env_id']}` | {r['supervisor']} | {n(r['bare_steps_per_s'])} | "
            f"{n(r['labelled_steps_per_s'])} | {r['label_overhead_pct']:.1f} % |"
        )
    return (
        "\n".join(out)
        + f"\n\nBest of {data['repeats']} interleaved blocks of {data['steps']} steps per side, "
        "wall clock. " + machine_line(data)
    )
