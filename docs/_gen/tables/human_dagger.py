"""docs/results/human_dagger.json (scripts/training/human_dagger.py)."""


def render(data, **_):
    rows = [
        "| iteration | datasets aggregated | state–label pairs | relabelled differently |"
        " mean return |",
        "|---|---|---|---|---|",
    ]
    for r in data["iterations"]:
        changed = "—" if r["iteration"] == 0 else f"{r['labels_changed']:.0%}"
        rows.append(
            f"| {r['iteration']} | {len(r['datasets'])} | {r['pairs']} | {changed} |"
            f" {r['mean_return']:.1f} |"
        )
    s = data["settings"]
    return (
        "\n".join(rows) + f"\n\n`{data['env_id']}`, a `{s['policy']}` learner; iteration 0 is BC on"
        f" {s['teleop_episodes']} episodes teleoperated by the simulated person ({s['human']});"
        f" each later iteration adds {s['rollouts']} learner rollouts relabelled by it"
        f" ({s['labeller']}). Mean return over {s['eval_episodes']} evaluation episodes (seeds"
        f" from {data['seeds']['evaluation']}); the supervisor's is"
        f" {data['supervisor_mean_return']:.1f} on the same episodes. Machine: {data['machine']};"
        f" {data['seconds']:.0f} s. Command: `{data['command']}`."
    )
