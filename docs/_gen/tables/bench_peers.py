"""docs/results/bench_peers.json (scripts/benchmarks/bench_peers.py --results): peers' step rate
next to FLUIDS', one process, one run."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # docs/_gen: benchfmt

from benchfmt import machine_line, n  # noqa: E402

ACTS = {"supervisor": "its supervisor (label every step)", "random": "random actions"}


def _settings(r: dict) -> str:
    kwargs = r.get("kwargs") or {}
    config = kwargs.get("config", kwargs)
    return ", ".join(f"`{k}={v}`" for k, v in config.items()) or "defaults"


def ratio_to(data: dict, name: str, reference: str) -> float:
    """How many times `reference`'s median steps per CPU-second `name`'s is (a test reads it)."""
    results = data["results"]
    return results[reference]["median_steps_per_cpu_s"] / results[name]["median_steps_per_cpu_s"]


def render(data, **_) -> str:
    out = [
        "| env | settings | who acts | steps per CPU-second: median (min–max over rounds) "
        "| steps/s (wall), median | steps per round × rounds |",
        "|---|---|---|---|---|---|",
    ]
    missing = []
    for name, r in data["results"].items():
        if "unavailable" in r:
            missing.append(f"**{name}**: {r['unavailable']}.")
            continue
        cpu, wall = r["steps_per_cpu_s"], r["steps_per_s"]
        out.append(
            f"| {name} (`{r['id']}`) | {_settings(r)} | {ACTS.get(r['policy'], r['policy'])} | "
            f"{n(r['median_steps_per_cpu_s'])} ({n(min(cpu))}–{n(max(cpu))}) | "
            f"{n(sorted(wall)[len(wall) // 2])} | {r['steps_per_round']} × {r['rounds']} |"
        )
    versions = ", ".join(f"{k} {v}" for k, v in data.get("versions", {}).items())
    notes = [
        f"Versions: {versions}. Timed: {data.get('timing', 'env.step')}.",
        *(["Not measured: " + " ".join(missing)] if missing else []),
        machine_line(data),
    ]
    return "\n".join(out) + "\n\n" + "\n\n".join(notes)
