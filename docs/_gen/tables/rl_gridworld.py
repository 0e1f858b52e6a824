"""docs/results/rl_gridworld.json (scripts/baselines/rl_baselines.py)."""


def render(data, **_):
    s = data["settings"]
    rows = [
        "| policy | mean return | training CPU (s) |",
        "|---|---|---|",
        f"| random | {data['random']['mean_return']:.1f} | 0 |",
    ]
    if "supervisor" in data:
        rows.append(f"| supervisor | {data['supervisor']['mean_return']:.1f} | 0 |")
    for run in data["runs"]:
        cpu = run["curve"][-1]["train_cpu_s"]
        rows.append(
            f"| {run['algo'].upper()} seed {run['seed']} | {run['final']['mean_return']:.1f} | "
            f"{cpu:.0f} |"
        )
    for algo, summ in data.get("summary", {}).items():
        verdict = "yes" if summ["beats_random_every_seed"] else "no"
        rows.append(
            f"| **{algo.upper()} mean of {len(summ['mean_return_seeds'])} seeds** | "
            f"**{summ['mean_return_mean']:.1f}** | beats random on every seed: {verdict} |"
        )
    return "\n".join(rows) + (
        f"\n\n`{data['env_id']}` (no success flag: compared by return): {s['steps']:,} env steps "
        f"per run, {s['hyperparameters']} with {s['n_envs']} envs; final evaluation on "
        f"{s['final_episodes']} episodes (seeds {s['eval_seeds']}, never used in training), "
        f"deterministic policy; the random policy on the same episodes. Machine: {s['machine']}."
    )
