"""docs/results/defensive_driving_v0_v1.json (scripts/quality/defensive_driving.py
`--defensive both --yield-to-pedestrians`): v0's planner against v1's on the same seeds.
"""

POLICIES = ("supervisor", "stop", "crawl", "random", "noisy")
LAYOUTS = ("four_way", "t_junction", "roundabout")


def _cell(s: dict) -> str:
    return f"{s['supervised_fault']} / {s['cut_in']} / {s['ego_fault']}"


def render(data, **_) -> str:
    summ = data["summary"]
    out = [
        "| layout | ego policy | v0 | v1 | ego arrived v0 → v1 |",
        "|---|---|---|---|---|",
    ]
    for layout in LAYOUTS:
        for pol in POLICIES:
            v0, v1 = summ.get(f"{layout}/{pol}/v0"), summ.get(f"{layout}/{pol}/v1")
            if v0 is None or v1 is None:
                continue
            out.append(
                f"| {layout} | {pol} | {_cell(v0)} | **{_cell(v1)}** | "
                f"{v0['arrived']} → {v1['arrived']} |"
            )
    per_planner = {m: 0 for m in ("v0", "v1")}
    fault_episodes = {m: 0 for m in ("v0", "v1")}
    for k, s in summ.items():
        mode = k.rsplit("/", 1)[1]
        if mode in per_planner:
            per_planner[mode] += s["episodes"]
            fault_episodes[mode] += s["supervised_fault_episodes"]
    cell = {s["episodes"] for s in summ.values()}
    out += [
        "",
        "Cells: collisions that were a supervised agent's fault (no cut-in) / cut-ins / the ego's "
        f"fault. {'/'.join(map(str, sorted(cell)))} episodes per cell "
        f"({data['settings']['episodes_per_scene']} per scene), {per_planner['v0']} per planner. "
        f"Episodes with a supervised agent at fault: {fault_episodes['v0']} with v0's planner, "
        f"{fault_episodes['v1']} with v1's.",
    ]
    return "\n".join(out)
