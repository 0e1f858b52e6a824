"""docs/results/rl_fluids_v2.json and rl_fluids_v2_2m.json (scripts/baselines/rl_baselines.py).

`bc=True` adds the imitation learners of docs/results/fluids_baselines.json (`FLUIDS-v1` in
physical units at the velocity level: the same scenes, success criterion and evaluation seeds)
and, per RL algorithm, whether every seed reaches BC's success.
"""

import json
from pathlib import Path

BASELINES = Path(__file__).resolve().parents[2] / "results" / "fluids_baselines.json"
IL_ROWS = {"bc_tree": "BC (tree)", "bc_mlp": "BC (MLP)", "dagger": "DAgger (tree)"}


def _se(r):
    p = r["success_rate"]
    return (p * (1 - p) / r["episodes"]) ** 0.5


def _row(name, r):
    cpu = f"{r['train_cpu_s']:.0f}" if "train_cpu_s" in r else "0"
    ret = "–" if r.get("mean_return") is None else f"{r['mean_return']:.2f}"
    return (
        f"| {name} | {r['success_rate']:.3f} ± {_se(r):.3f} | {r.get('collision', '')} | "
        f"{r.get('red_light_runs', '')} | {r.get('failed_to_yield', '')} | "
        f"{r.get('timeouts', '')} | {ret} | {cpu} |"
    )


def _il_rows() -> dict:
    """The learners on FLUIDS-v1 from fluids_baselines.json, in this table's field names."""
    rows = {}
    for r in json.loads(BASELINES.read_text()):
        if r["env_id"] == "FLUIDS-v1" and r["method"] in IL_ROWS:
            rows[r["method"]] = {**r, "collision": r["collision_episodes"], "mean_return": None}
    return rows


def render(data, bc=False, **_):
    s = data["settings"]
    rows = [
        "| policy | success ± s.e. | episodes with a collision | red-light runs | failed to yield | timeouts | "
        "mean return | training CPU (s) |",
        "|---|---|---|---|---|---|---|---|",
        _row("random", data["random"]),
    ]
    if "supervisor" in data:
        rows.append(_row("supervisor", data["supervisor"]))
    il = _il_rows() if bc else {}
    for method, r in il.items():
        rows.append(_row(f"{IL_ROWS[method]}, `FLUIDS-v1`", r))
    for run in data["runs"]:
        name = f"{run['algo'].upper()} seed {run['seed']}"
        if run["final"] is None:  # still training: its last curve point
            if run["curve"]:
                last = run["curve"][-1]
                rows.append(_row(f"{name}, unfinished: {last['steps']:,} steps so far", last))
            continue
        final = {**run["final"], "train_cpu_s": run["curve"][-1]["train_cpu_s"]}
        rows.append(_row(name, final))
    for algo, summ in data.get("summary", {}).items():
        verdict = "yes" if summ["beats_random_every_seed"] else "no"
        cell = f"beats random on every seed: {verdict}"
        if "bc_tree" in il:
            reach = all(v >= il["bc_tree"]["success_rate"] for v in summ["success_rate_seeds"])
            cell += f"; reaches BC (tree) on every seed: {'yes' if reach else 'no'}"
            mean_reach = summ["success_rate_mean"] >= il["bc_tree"]["success_rate"]
            cell += f"; mean reaches BC (tree): {'yes' if mean_reach else 'no'}"
        rows.append(
            f"| **{algo.upper()} mean of {len(summ['success_rate_seeds'])} seeds** | "
            f"**{summ['success_rate_mean']:.3f}** | | | | | | {cell} |"
        )
    kwargs = data["env_kwargs"]
    text = (
        f"\n\n`{data['env_id']}` with `{kwargs}`: {s['steps']:,} env steps per run, "
        f"{s['hyperparameters']} with {s['n_envs']} envs; final evaluation on "
        f"{s['final_episodes']} episodes (seeds {s['eval_seeds']}, never used in training), "
        f"deterministic policy; the random policy on the same episodes. Curve points every "
        f"{s['eval_every']:,} steps on {s['eval_episodes']} of those episodes. "
        f"Machine: {s['machine']}."
    )
    if il:
        text += (
            " The imitation learners are `docs/results/fluids_baselines.json`'s rows: "
            "`FLUIDS-v1` in physical units at the velocity level (the same scenes, success "
            "criterion and evaluation seeds as these episodes), trained on 60 supervisor rollouts."
        )
    return "\n".join(rows) + text
