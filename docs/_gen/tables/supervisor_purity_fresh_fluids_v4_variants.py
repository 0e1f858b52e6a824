"""Renderer of docs/results/supervisor_purity_fresh_fluids_v4_variants.json: the fresh-supervisor
check (scripts/checks/supervisor_purity.py --copy fresh) on FLUIDS-v4 with other kwargs, one run
per row, each with its command."""

from __future__ import annotations

import json


def render(data: dict, **_) -> str:
    lines = [
        "| `FLUIDS-v4` kwargs | random: labels that differ | noisy supervisor |",
        "|---|---|---|",
    ]
    commands = []
    for run in data["runs"]:
        kwargs = ", ".join(f"`{k}={json.dumps(v)}`" for k, v in run["env_kwargs"].items())
        r = run["results"]["FLUIDS-v4"]
        lines.append(
            f"| {kwargs} | {r['random']['label']} / {r['random']['states']} "
            f"| {r['noisy']['label']} / {r['noisy']['states']} |"
        )
        commands.append(f"`{run['command']}`")
    return (
        "\n".join(lines)
        + "\n\n<small>From `docs/results/supervisor_purity_fresh_fluids_v4_variants.json`, "
        + "written by "
        + "; ".join(commands)
        + ".</small>"
    )
