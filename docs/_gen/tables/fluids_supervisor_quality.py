"""docs/results/fluids_supervisor_quality.json (scripts/quality/supervisor_quality.py --results).

`part="summary"`: one row per layout; `part="grid"` (with `layout=`): cars × pedestrians.
"""

NAMES = {"four_way": "four-way", "t_junction": "T-junction", "roundabout": "roundabout"}


def _pct(k: int, n: int) -> str:
    return f"{100 * k / n:.2f} %"


def render(data, part: str = "summary", layout: str = "four_way", **_) -> str:
    s = data["settings"]
    per_scene = s["episodes_per_scene"]
    if part == "grid":
        rep = next(r for r in data["layouts"] if r["layout"] == layout)
        peds = list(range(s["pedestrians"][0], s["pedestrians"][1] + 1))
        cars = list(range(s["cars"][0], s["cars"][1] + 1))
        cell = {(r["cars"], r["pedestrians"]): r for r in rep["scenes"]}
        out = [
            f"Successful episodes of {per_scene} per scene, {NAMES[layout]}:",
            "",
            "| cars \\ pedestrians | " + " | ".join(map(str, peds)) + " |",
            "|---" * (len(peds) + 1) + "|",
        ]
        for c in cars:
            cells = [f"{cell[c, p]['success']}/{cell[c, p]['episodes']}" for p in peds]
            out.append(f"| {c} | " + " | ".join(cells) + " |")
        return "\n".join(out)
    out = [
        f"| layout | episodes ({per_scene} per scene) | success | with a collision | deadlocks |",
        "|---|---|---|---|---|",
    ]
    for r in data["layouts"]:
        success = sum(x["success"] for x in r["scenes"])
        out.append(
            f"| {NAMES.get(r['layout'], r['layout'])} | {r['episodes']} | "
            f"{success}/{r['episodes']} ({_pct(success, r['episodes'])}) | "
            f"{r['collision_episodes']} | {r['deadlocks']} |"
        )
    m = data.get("machine", {})
    out += [
        "",
        f"Scenes: {s['cars'][0]}–{s['cars'][1]} cars × {s['pedestrians'][0]}–"
        f"{s['pedestrians'][1]} pedestrians, seeds {s['seeds']}, a deadlock after "
        f"{s['max_steps']} steps; {data['wall_seconds'] / 60:.0f} min wall with "
        f"{s['workers']} worker{'s' if s['workers'] > 1 else ''} on a shared "
        f"{m.get('cpu_count', '?')}-core machine.",
    ]
    return "\n".join(out)
