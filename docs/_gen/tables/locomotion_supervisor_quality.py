"""Renderer of docs/results/locomotion_supervisor_quality.json.

Parts: `"supervisor"` (default: the shipped supervisors' returns against the source's
experts), `"noise"` (returns with noise injected into the executed action) and
`"tolerance"` (the share of the clean return kept under the noise targets' levels, falls) and
`"training"` (the shipped policies' training records, from the weights manifest).
"""

from __future__ import annotations

ORDER = ("Hopper-IL-v0", "Walker2d-IL-v0", "HalfCheetah-IL-v0", "Humanoid-IL-v0")


def _n(x: float) -> str:
    return f"{x:,.0f}"


def _rows(data: dict) -> list[dict]:
    return sorted(data["rows"], key=lambda r: (ORDER.index(r["env_id"]), r["noise_std"]))


def _supervisor_name(data: dict, row: dict) -> str:
    if row["kind"] != "policy":
        return row["kind"]
    shipped = data["shipped"][row["env_id"].split("-")[0]]
    return f"policy (ARS, iteration {shipped['selected_at_iteration']})"


NEVER_TERMINATES = ("HalfCheetah-IL-v0",)  # Gymnasium's HalfCheetah has no termination


def _falls(row: dict) -> str:
    if row["env_id"] in NEVER_TERMINATES:
        return "–"
    return f"{row['falls']} / {row['episodes']}"


def supervisor(data: dict) -> str:
    lines = [
        "| env | default supervisor | return | min | falls | source's TRPO expert | ms / label |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in _rows(data):
        if r["noise_std"] != 0:
            continue
        lines.append(
            f"| `{r['env_id']}` | {_supervisor_name(data, r)} | **{_n(r['mean_return'])} ± {_n(r['std_return'])}** "
            f"| {_n(r['min_return'])} | {_falls(r)} | {_n(r['source_expert'])} | {r['ms_per_label']:.2f} |"
        )
    lines += [
        "",
        f"Mean ± standard deviation over seeded episodes of {data['steps']:,} steps (seeds {data['seeds']}); "
        f"a fall is an episode that terminated early; ms / label: the label alone, median; {data['machine']}.",
    ]
    return "\n".join(lines)


def noise(data: dict) -> str:
    levels = sorted({r["noise_std"] for r in data["rows"]})
    by = {(r["env_id"], r["noise_std"]): r for r in data["rows"]}
    lines = [
        "| env | " + " | ".join(f"σ = {s:g}" for s in levels) + " |",
        "|---|" + "---|" * len(levels),
    ]
    for env_id in [e for e in ORDER if any(k[0] == e for k in by)]:
        cells = []
        for s in levels:
            r = by.get((env_id, s))
            if r is None:
                cells.append("")
                continue
            cell = f"{_n(r['mean_return'])} ± {_n(r['std_return'])}"
            if r["env_id"] not in NEVER_TERMINATES:
                cell += f", falls {_falls(r)}"
            if r["flipped_share"] > 0.005:
                cell += f", on its back {100 * r['flipped_share']:.0f}% of steps"
            cells.append(cell)
        lines.append(f"| `{env_id}` | " + " | ".join(cells) + " |")
    lines += [
        "",
        f"Return over {data['steps']:,}-step episodes (seeds {data['seeds']}), mean ± standard deviation; "
        f"noise: {data['noise']}.",
    ]
    return "\n".join(lines)


def tolerance(data: dict) -> str:
    """Clean return, and the share of it kept under each targeted noise level, with falls."""
    targets = data.get("noise_targets", [])
    by = {(r["env_id"], r["noise_std"]): r for r in data["rows"]}
    head = "| env | clean return |"
    for t in targets:
        head += f" σ = {t['noise_std']:g}: return (% of clean), falls |"
    lines = [head + " targets met |", "|---|---|" + "---|" * len(targets) + "---|"]
    for env_id in [e for e in ORDER if (e, 0.0) in by]:
        clean = by[(env_id, 0.0)]
        cells, met = [f"{_n(clean['mean_return'])}"], True
        for t in targets:
            r = by.get((env_id, t["noise_std"]))
            if r is None:
                cells.append("not measured")
                met = False
                continue
            share = r["mean_return"] / clean["mean_return"]
            cell = f"{_n(r['mean_return'])} ({100 * share:.0f} %)"
            if env_id in NEVER_TERMINATES:  # it never falls: time on its back is its failure
                fell = r["flipped_share"] > 0
                cell += f", on its back {100 * r['flipped_share']:.1f} % of steps"
            else:
                fell = r["falls"] > 0
                cell += f", falls {_falls(r)}"
            cells.append(cell)
            met &= share >= t["min_share_of_clean"] and not (fell and t["no_falls"])
        lines.append(f"| `{env_id}` | " + " | ".join(cells) + f" | {'yes' if met else '**no**'} |")
    rules = "; ".join(
        f"σ = {t['noise_std']:g}: ≥ {100 * t['min_share_of_clean']:.0f} % of the clean return"
        + (" and no falls" if t["no_falls"] else "")
        for t in targets
    )
    lines += [
        "",
        f"Targets: {rules}; HalfCheetah never terminates, so its fall is a step on its back. "
        f"{data['episodes']} seeded episodes of {data['steps']:,} steps per cell (seeds {data['seeds']}); "
        f"noise: {data['noise']}.",
    ]
    return "\n".join(lines)


def training(data: dict) -> str:
    lines = [
        "| task | ARS V2-t settings | shipped iteration | training env steps (whole run) | training evaluation |",
        "|---|---|---|---|---|",
    ]
    for env_id in ORDER:
        name = env_id.split("-")[0]
        s = data["shipped"].get(name)
        if s is None:
            continue

        def settings(r: dict) -> str:
            text = (
                f"N = {r['n_directions']}, b = {r['top']}, α = {r['step_size']:g}, "
                f"ν = {r['noise']:g}, shift {r['shift']:g}, seed {r['seed']}"
            )
            text += ", linear + tanh" if not r.get("hidden") else f", hidden {r['hidden']}"
            if r.get("action_noise"):
                text += f", trained under action noise σ = {r['action_noise']:g}"
            if r.get("paired_seeds"):
                text += " (`--paired-seeds`)"
            return text

        stages = s["stages"]
        if len(stages) == 1:
            text = settings(stages[0]["recipe"])
        else:
            parts = []
            for i, stage in enumerate(stages):
                how = {
                    None: "",
                    "checkpoint": " (`--init` from the previous stage's checkpoint at "
                    f"iteration {stage['started_at_iteration']})",
                    "weights": " (`--init-weights` from the previous stage's weight file, "
                    f"iteration {stage['started_at_iteration']})",
                }[stage["from"]]
                parts.append(f"stage {i + 1}{how}: {settings(stage['recipe'])}")
            text = "; ".join(parts)
        lines.append(
            f"| {name} | {text} | {s['selected_at_iteration']} | {s['training_env_steps'] / 1e6:.2f} M "
            f"| {_n(s['training_eval_mean_return'])} ({s['training_eval_episodes']} episodes) |"
        )
    lines += [
        "",
        "From `fluids_bench/tasks/locomotion/weights/manifest.json` (each file's sha256 and full recipe "
        "are recorded there and checked when the file is loaded). Training evaluation: the "
        "selected policy's mean return over the run's evaluation episodes; for a stage trained "
        "under action noise, over its clean and its noisy ones (the same seeds).",
    ]
    return "\n".join(lines)


def render(data: dict, part: str = "supervisor", **options) -> str:
    parts = {
        "supervisor": supervisor,
        "noise": noise,
        "tolerance": tolerance,
        "training": training,
    }
    if part not in parts:
        raise ValueError(f"part is {part!r}; allowed: {sorted(parts)}")
    return parts[part](data)
