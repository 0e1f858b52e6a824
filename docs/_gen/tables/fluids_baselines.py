"""docs/results/fluids_baselines.json (scripts/baselines/fluids_baselines.py): one row per
(env, method), 200 seeded evaluation episodes each.

`part="full"`: every column; `part="success"`: success rate per method, the envs side by side.
"""

COMMAND = (
    "python scripts/baselines/fluids_baselines.py --episodes 200 --demos 60 --ppo-steps 100000 "
    "--out docs/results/fluids_baselines.json"
)
NAMES = {
    "random": "random",
    "constant": "constant 5 m/s",
    "supervisor": "supervisor",
    "bc_tree": "BC (tree)",
    "bc_mlp": "BC (MLP)",
    "dagger": "DAgger (tree)",
    "dart": "DART (tree)",
    "ppo": "PPO (SB3 MLP)",
}


def _footer(data) -> str:
    return f"\n\n<small>From `docs/results/fluids_baselines.json`, written by `{COMMAND}`.</small>"


def render(data, part: str = "full", **_) -> str:
    rows = data
    if part == "success":
        envs = list(dict.fromkeys(r["env_id"] for r in rows))
        methods = list(dict.fromkeys(r["method"] for r in rows))
        cell = {(r["env_id"], r["method"]): r for r in rows}
        out = [
            "| method | " + " | ".join(f"`{e}`" for e in envs) + " |",
            "|---" * (len(envs) + 1) + "|",
        ]
        for m in methods:
            cells = []
            for e in envs:
                r = cell.get((e, m))
                cells.append(
                    "–"
                    if r is None
                    else f"{r['success_rate']:.3f} ({r['success']}/{r['episodes']})"
                )
            out.append(f"| {NAMES.get(m, m)} | " + " | ".join(cells) + " |")
        return "\n".join(out) + _footer(data)
    cols = [
        ("success", lambda r: f"{r['success']}/{r['episodes']}"),
        ("collision episodes", lambda r: r["collision_episodes"]),
        ("ego at fault", lambda r: r["ego_fault"]),
        ("supervised at fault", lambda r: r["supervised_fault"]),
        ("cut-ins", lambda r: r["cut_in"]),
        ("red-light runs", lambda r: r["red_light_runs"]),
        ("failed to yield", lambda r: r["failed_to_yield"]),
        ("timeouts", lambda r: r["timeouts"]),
        (
            "mean time to goal (s)",
            lambda r: (
                "–" if r["mean_time_to_goal_s"] is None else f"{r['mean_time_to_goal_s']:.2f}"
            ),
        ),
        ("training CPU (s)", lambda r: f"{r['train_cpu_s']:.1f}"),
    ]
    out = [
        "| env (velocity level) | method | " + " | ".join(c for c, _ in cols) + " |",
        "|---" * (len(cols) + 2) + "|",
    ]
    for r in rows:
        out.append(
            f"| {r['env_id']} | {NAMES.get(r['method'], r['method'])} | "
            + " | ".join(str(f(r)) for _, f in cols)
            + " |"
        )
    return "\n".join(out) + _footer(data)
