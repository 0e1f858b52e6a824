"""Renderer of docs/results/fluids_v4_scores*.json (scripts/benchmarks/fluids_driving_score.py):
each policy's mean driving score with its 95 % bootstrap interval, route completion, success and
infraction counts on the test seeds. `policies=[...]` shows only those rows."""

from __future__ import annotations


def render(data: dict, policies=None, **options) -> str:
    lines = [
        "| policy | driving score [95 % interval] | route completion | success "
        "| infractions (summed over episodes) |",
        "|---|---|---|---|---|",
    ]
    for name, v in data["policies"].items():
        if policies is not None and name not in policies:
            continue
        ds = v["driving_score"]
        counts = ", ".join(f"{k.replace('_', ' ')} {c}" for k, c in v["infractions"].items() if c)
        lines.append(
            f"| {name} | {ds['mean']:.3f} [{ds['low']:.3f}, {ds['high']:.3f}] "
            f"| {v['route_completion']['mean']:.3f} | {v['success']['mean']:.2f} "
            f"| {counts or 'none'} |"
        )
    seeds = data["test_seeds"]
    episodes = next(iter(data["policies"].values()))["episodes"]
    notes = [f"{episodes} test episodes, seeds {seeds[0]}–{seeds[1]}"]
    if data.get("env_kwargs"):
        notes.append(f"env kwargs {data['env_kwargs']}")
    shown = data["policies"] if policies is None else policies
    if "bc_labels" in data and "bc" in shown:
        notes.append(f"BC fitted on {data['bc_labels']} labels")
    if "dagger_labels" in data and "dagger" in shown:
        notes.append(f"DAgger on {data['dagger_labels']}")
    if "random_over_supervisor" in data:
        notes.append(f"random / supervisor = {data['random_over_supervisor']:.3f}")
    machine = data.get("machine", {})
    if machine:
        notes.append(f"{machine.get('cpu_model')} × {machine.get('cpu_count')} (shared)")
    return "\n".join(lines) + "\n\n" + "; ".join(notes) + "."
