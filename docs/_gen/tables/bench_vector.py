"""docs/results/bench_vector.json (scripts/benchmarks/bench_vector.py --results): batched FLUIDS.

Parts: `batch` (default: env-steps per CPU-second by B), `agents` (scaling in agents),
`processes` (one process vs two on two cores), `workers` (one batch in one process vs over
two with `num_workers=2`), `profile` (where a vector step's time goes),
`kernels` (the time inside the step's compiled calls).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # docs/_gen: benchfmt

from benchfmt import machine_line, n  # noqa: E402

KINDS = {
    "scalar": "scalar env (`gym.make`)",
    "sync": "`SyncVectorEnv`",
    "vector": "vector entry point",
}


def _batch(data) -> str:
    out = [
        "| env | B | env-steps per CPU-second | × scalar | CPU µs per agent-step | env-steps timed |",
        "|---|---|---|---|---|---|",
    ]
    for r in data["batch"]:
        b = "–" if r["env"] == "scalar" else r["num_envs"]
        out.append(
            f"| {KINDS[r['env']]} | {b} | {n(r['steps_per_cpu_s'])} | {r['vs_scalar']:.2f} | "
            f"{r['us_per_agent_step']:.1f} | {r['env_steps']:,} |"
        )
    scene = data["scene"]
    return (
        "\n".join(out) + f"\n\n`{data['env_id']}` S2: the ego + {scene['num_cars']} cars + "
        f"{scene['num_pedestrians']} pedestrians ({data['batch'][0]['agents']} agents), "
        f"{scene['obs_type']} observation, {scene['action_level']} level, the ego following the "
        f"label; pinned to core {data['pinned_core']}. " + machine_line(data)
    )


def _agents(data) -> str:
    out = [
        "| cars | agents | env-steps per CPU-second | CPU µs per agent-step |",
        "|---|---|---|---|",
    ]
    for r in data["agents"]:
        cars = r["agents"] - 1 - data["scene"]["num_pedestrians"]
        out.append(
            f"| {cars} | {r['agents']} | {n(r['steps_per_cpu_s'])} | {r['us_per_agent_step']:.1f} |"
        )
    return (
        "\n".join(out)
        + f"\n\nVector entry point, B = {data['agents_batch']}, the two-lane four-way (it holds "
        "31 cars with the ego), plus the ego and 5 pedestrians."
    )


def _processes(data) -> str:
    p = data.get("processes")
    if not p:
        return "(not measured: the run had fewer than two cores)"
    out = ["| processes | cores | env-steps per wall-second |", "|---|---|---|"]
    for r in p["runs"].values():
        out.append(
            f"| {r['processes']} | {', '.join(map(str, r['cores']))} | {n(r['steps_per_s'])} |"
        )
    return (
        "\n".join(out) + f"\n\nEach process steps a vector env of B = {p['num_envs']} for "
        f"{p['batch_steps_per_process']} batch steps. Two processes give **{p['ratio']:.2f}×** "
        "one (wall-clock, on a machine shared with other jobs: see the load average above)."
    )


def _workers(data) -> str:
    w = data.get("workers")
    if not w:
        return "(not measured in this run)"
    return (
        "| one batch of B worlds | env-steps per wall-second (median block) |\n|---|---|\n"
        f"| one process | {n(w['one_process_steps_per_s'])} |\n"
        f"| `num_workers=2` | {n(w['two_workers_steps_per_s'])} |\n\n"
        f"B = {w['num_envs']}, {w['blocks']} alternating blocks of {w['block_steps']} batch "
        f"steps on the same worlds. Two workers give **{w['ratio']:.2f}×** one process (the "
        "median of the blocks' ratios)."
    )


def _profile(data) -> str:
    p = data["profile"]
    out = ["| part of the step | share of the time |", "|---|---|"]
    for k, v in p["fractions"].items():
        out.append(f"| {k} | {100 * v:.1f} % |")
    return (
        "\n".join(out) + f"\n\ncProfile of the vector entry point at B = {p['num_envs']}, "
        f"{p['batch_steps']} batch steps (a deterministic profiler inflates Python calls: "
        "read shares, not times)."
    )


def _kernels(data) -> str:
    k = data.get("kernels")
    if not k:
        return "(not measured in this run)"
    out = ["| compiled call | CPU µs per env-step |", "|---|---|"]
    for name, us in k["by_call"].items():
        out.append(f"| {name} | {us:.2f} |")
    out.append(f"| **all compiled calls** | **{k['compiled_us_per_env_step']:.2f}** |")
    out.append(f"| the whole step | {k['us_per_env_step']:.2f} |")
    return (
        "\n".join(out) + f"\n\nVector entry point at B = {k['num_envs']}, {k['env_steps']:,} "
        "env-steps; each compiled call of the step timed (CPU time) by a wrapper."
    )


PARTS = {
    "batch": _batch,
    "agents": _agents,
    "processes": _processes,
    "workers": _workers,
    "profile": _profile,
    "kernels": _kernels,
}


def render(data, part: str = "batch", **_) -> str:
    if part not in PARTS:
        raise ValueError(f"bench_vector: part is {part!r}; allowed: {sorted(PARTS)}")
    return PARTS[part](data)
