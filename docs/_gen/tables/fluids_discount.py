"""docs/results/fluids_discount.json (scripts/baselines/fluids_discount.py): trained policies'
returns on FLUIDS-v2 undiscounted and at PPO's discount, with failure weights 1 and another."""


def render(data, **_):
    low, high = data["penalties"]
    g = data["gamma"]
    rows = [
        f"| policy | success | mean length (steps) | return, failure weight {low:g} | "
        f"discounted return (γ = {g}), weight {low:g} | return, weight {high:g} | "
        f"discounted return (γ = {g}), weight {high:g} |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, r in data["policies"].items():
        rows.append(
            f"| {name} | {r['success_rate']:.2f} | {r['mean_length']:.0f} | {r['return'][0]:.2f} | "
            f"{r['discounted_return'][0]:.2f} | {r['return'][1]:.2f} | "
            f"{r['discounted_return'][1]:.2f} |"
        )
    return "\n".join(rows) + (
        f"\n\n`{data['env_id']}` with `{data['env_kwargs']}`, {r['episodes']} episodes each "
        f"(seeds {data['eval_seeds']}), the same episodes for every policy; the two weights' "
        "rewards come from the same rollouts (the weight changes no dynamics)."
    )
