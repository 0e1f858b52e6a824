"""docs/results/rl_{dag,singulation,grasping,track}.json (scripts/baselines/rl_baselines.py):
random, the supervisor and each RL run on the same evaluation episodes."""


def _success(r):
    p = r["success_rate"]
    return f"{p:.3f} ± {(p * (1 - p) / r['episodes']) ** 0.5:.3f}"


def render(data, **_):
    s = data["settings"]
    by_success = data["random"]["metric"] == "success_rate"
    head = (
        "| policy | "
        + ("success ± s.e. | " if by_success else "")
        + ("mean return | mean length (steps) | training CPU (s) |")
    )
    rows = [head, "|---" * (head.count("|") - 1) + "|"]

    def row(name, r, cpu):
        cells = [name] + ([_success(r)] if by_success else [])
        cells += [f"{r['mean_return']:.2f}", f"{r['mean_length']:.1f}", cpu]
        return "| " + " | ".join(cells) + " |"

    rows.append(row("random", data["random"], "0"))
    rows.append(row("supervisor", data["supervisor"], "0"))
    for run in data["runs"]:
        if not run["curve"]:
            continue
        last = run["curve"][-1]
        name = f"{run['algo'].upper()} seed {run['seed']}"
        if run["final"] is None:  # still training: its last curve point
            name += f", unfinished: {last['steps']:,} steps so far"
        rows.append(row(name, run["final"] or last, f"{last['train_cpu_s']:.0f}"))
    metric = data["random"]["metric"]
    for algo, summ in data.get("summary", {}).items():
        verdict = "yes" if summ["beats_random_every_seed"] else "no"
        value = f"**{summ[f'{metric}_mean']:.3f}**" if by_success else ""
        ret = "" if by_success else f"**{summ[f'{metric}_mean']:.2f}**"
        cells = [f"**{algo.upper()} mean of {len(summ[f'{metric}_seeds'])} seeds**"]
        cells += ([value] if by_success else []) + [
            ret,
            "",
            f"beats random on every seed: {verdict}",
        ]
        rows.append("| " + " | ".join(cells) + " |")
    kwargs = f" with `{data['env_kwargs']}`" if data["env_kwargs"] else ""
    compared = "success" if by_success else "return (no success flag)"
    return "\n".join(rows) + (
        f"\n\n`{data['env_id']}`{kwargs}, compared by {compared}: {s['steps']:,} env steps per "
        f"run, {s['hyperparameters']} with {s['n_envs']} envs; final evaluation on "
        f"{s['final_episodes']} episodes (seeds {s['eval_seeds']}, never used in training), "
        f"deterministic policy; random actions and the supervisor on the same episodes. Curve "
        f"points every {s['eval_every']:,} steps on the first {s['eval_episodes']} of those "
        f"episodes. Machine: {s['machine']}."
    )
