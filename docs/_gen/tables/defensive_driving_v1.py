"""docs/results/defensive_driving_v1.json (scripts/quality/defensive_driving.py, v1's planner).

Per layout and ego policy: collisions that were a supervised agent's fault (no cut-in) / cut-ins /
the ego's fault, and the episodes in which the ego arrived.
"""

POLICIES = ("supervisor", "stop", "crawl", "random", "noisy")
LAYOUTS = ("four_way", "t_junction", "roundabout")
# the file predates the script's "command" key: the command that wrote it
COMMAND = (
    "python scripts/quality/defensive_driving.py --episodes 200 --defensive on "
    "--yield-to-pedestrians --workers 2 --out docs/results/defensive_driving_v1.json"
)


def render(data, **_) -> str:
    summ = data["summary"]
    episodes = {s["episodes"] for s in summ.values()}
    out = [
        "| layout | " + " | ".join(POLICIES) + " |",
        "|---" * (len(POLICIES) + 1) + "|",
    ]
    for layout in LAYOUTS:
        cells = []
        for pol in POLICIES:
            s = summ[f"{layout}/{pol}/v1"]
            cells.append(
                f"{s['supervised_fault']} / {s['cut_in']} / {s['ego_fault']}, {s['arrived']}"
            )
        out.append(f"| {layout} | " + " | ".join(cells) + " |")
    total = sum(s["episodes"] for s in summ.values())
    per_scene = {r["episodes"] for r in data["scenes"]}
    out += [
        "",
        f"Cells: supervised at fault / cut-ins / ego at fault (collisions), ego arrived; "
        f"{'/'.join(map(str, sorted(episodes)))} episodes per cell "
        f"({'/'.join(map(str, sorted(per_scene)))} per scene), {total} in all.",
    ]
    if "command" not in data:
        out.append(
            f"\n<small>From `docs/results/defensive_driving_v1.json`, written by `{COMMAND}`.</small>"
        )
    return "\n".join(out)
