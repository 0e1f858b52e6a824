"""docs/results/fluids_ppo_ablation.json (scripts/baselines/rl_baselines.py --ablation)."""


def _row(name, r):
    return (
        f"| {name} | {r['success_rate']:.2f} | {r['collision']} | {r['red_light_runs']} | "
        f"{r['failed_to_yield']} | {r['timeouts']} | {r['mean_first_action']:.2f} | "
        f"{r['mean_length']:.0f} |"
    )


def render(data, **_):
    s = data["settings"]
    n = s["final_episodes"]
    rows = [
        "| PPO on `FLUIDS-v1`, velocity level, with | success | collisions | red-light runs | "
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
