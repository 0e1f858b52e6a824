"""docs/results/rl_multi_agent_recipe.json (scripts/baselines/multi_agent_recipe.py)."""


def render(data, **_):
    s = data["settings"]
    ret = data["last_episodes_mean_return"]
    return "\n".join(
        [
            "| total_timesteps | steps taken | CPU time | wall time | episodes in SB3's buffer, "
            'mean return | "render_mode" warnings |',
            "|---|---|---|---|---|---|",
            f"| {s['total_timesteps']:,} | {data['steps_taken']:,} | {data['cpu_s'] / 60:.1f} min "
            f"| {data['wall_s'] / 60:.1f} min | {data['last_episodes']}, "
            f"{'' if ret is None else f'{ret:.2f}'} | {data['render_mode_warnings']} |",
        ]
    ) + (
        f"\n\n`{data['env_id']}`, {s['controlled_cars']} controlled cars × {s['copies']} worlds = "
        f"{s['sub_envs']} sub-envs, {s['hyperparameters']}, seed {data['seeds'][0]}; PPO takes "
        f"whole rollouts (2,048 steps per sub-env), hence more steps than asked. "
        f"Machine: {s['machine']}."
    )
