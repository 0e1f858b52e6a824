"""docs/results/fluids_ppo_ablation.json (scripts/baselines/rl_baselines.py --ablation)."""


def _row(name, r):
    return (
        f"| {name} | {r['success_rate']:.2f} | {r['collision']} | {r['red_light_runs']} | "
        f"{r['failed_to_yield']} | {r['timeouts']} | {r['mean_first_action']:.2f} | "
        f"{r['mean_length']:.0f} |"
    )


def diagnosis(data):
    d = data["diagnosis"]
    a, r, n, o = d["action"], d["reward"], d["length"], d["observation"]
    ap, an = a["physical"], a["normalized"]
    rows = [
        "| what | measured with v1's defaults | with the v2 option |",
        "|---|---|---|",
        f"| action scale: an untrained PPO policy's Gaussian samples (mean 0, std 1) below the "
        f"Box, clipped to 0 m/s; its mean target speed | {ap['below_box']:.0%} below "
        f"`[0, {ap['box'][1]:g}]`; {ap['mean_target_speed']:.2f} m/s | {an['below_box']:.0%} "
        f"below `[-1, 1]`; {an['mean_target_speed']:.2f} m/s |",
        f"| reward: failed episodes (of {r['failed_episodes']}, random target speeds, "
        f"{r['episodes']} episodes) returning at least as much as the worst success | "
        f"{r['failed_at_least_worst_success_v0']} | {r['failed_at_least_worst_success_v1']} |",
    ]
    for kind, e in r["by_outcome"].items():
        rows.append(
            f"| mean return of the random policy's episodes: {kind} ({e['episodes']}) | "
            f"{e['mean_return_v0']:.2f} | {e['mean_return_v1']:.2f} |"
        )
    rows += [
        f"| episode length: the supervisor's steps to the goal (step limit {n['step_limit']}); "
        f"PPO's discount γ = {n['gamma']} of its arrival | {n['supervisor_mean_steps']:.0f} "
        f"steps; {n['discount_at_supervisor_arrival']:.3f} | the same (an option for neither) |",
        f"| observation scale: explicit vector's per-entry standard deviation (min to max) and "
        f"largest magnitude | {o['physical']['std_min']:.2f} to {o['physical']['std_max']:.1f}; "
        f"{o['physical']['abs_max']:.0f} | {o['normalized']['std_min']:.2f} to "
        f"{o['normalized']['std_max']:.2f}; {o['normalized']['abs_max']:.0f} |",
    ]
    return "\n".join(rows)


def render(data, part=None, **_):
    if part == "diagnosis":
        return diagnosis(data)
    s = data["settings"]
    n = s["final_episodes"]
    rows = [
        "| PPO on `FLUIDS-v1`, velocity level, with | success | episodes with a collision | red-light runs | "
        "failed to yield | timeouts | mean target speed (m/s) | mean length (steps) |",
        "|---|---|---|---|---|---|---|---|",
        _row("random target speed (no training)", data["random"]),
    ]
    for arm in data["arms"]:
        rows.append(_row(arm["arm"], arm))
    return "\n".join(rows) + (
        f"\n\nOne training seed ({data['seeds'][0]}), {s['steps']:,} env steps each, "
        f"{s['hyperparameters']} with {s['n_envs']} envs; counts over {n} evaluation episodes "
        f"(seeds {s['eval_seeds']}), deterministic policy. Machine: {s['machine']}."
    )
