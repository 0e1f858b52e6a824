"""docs/results/rl_fluids_v2.json (scripts/baselines/rl_baselines.py)."""


def _se(r):
    p = r["success_rate"]
    return (p * (1 - p) / r["episodes"]) ** 0.5


def _row(name, r):
    cpu = f"{r['train_cpu_s']:.0f}" if "train_cpu_s" in r else "0"
    return (
        f"| {name} | {r['success_rate']:.3f} ± {_se(r):.3f} | {r.get('collision', '')} | "
        f"{r.get('red_light_runs', '')} | {r.get('failed_to_yield', '')} | "
        f"{r.get('timeouts', '')} | {r['mean_return']:.2f} | {cpu} |"
    )


def render(data, **_):
    s = data["settings"]
    rows = [
        "| policy | success ± s.e. | episodes with a collision | red-light runs | failed to yield | timeouts | "
        "mean return | training CPU (s) |",
        "|---|---|---|---|---|---|---|---|",
        _row("random", data["random"]),
    ]
    for run in data["runs"]:
        final = {**run["final"], "train_cpu_s": run["curve"][-1]["train_cpu_s"]}
        rows.append(_row(f"{run['algo'].upper()} seed {run['seed']}", final))
    for algo, summ in data.get("summary", {}).items():
        verdict = "yes" if summ["beats_random_every_seed"] else "no"
        rows.append(
            f"| **{algo.upper()} mean of {len(summ['success_rate_seeds'])} seeds** | "
            f"**{summ['success_rate_mean']:.3f}** | | | | | | beats random on every seed: "
            f"{verdict} |"
        )
    kwargs = data["env_kwargs"]
    return "\n".join(rows) + (
        f"\n\n`{data['env_id']}` with `{kwargs}`: {s['steps']:,} env steps per run, "
        f"{s['hyperparameters']} with {s['n_envs']} envs; final evaluation on "
        f"{s['final_episodes']} episodes (seeds {s['eval_seeds']}, never used in training), "
        f"deterministic policy; the random policy on the same episodes. Curve points every "
        f"{s['eval_every']:,} steps on {s['eval_episodes']} of those episodes. "
        f"Machine: {s['machine']}."
    )
