"""docs/results/sweep_hopper.json (scripts/reproductions/sensitivity_study.py --tasks hopper)."""

import math

NOMINAL = {"body_mass_scale": 1.0, "friction_scale": 1.0, "actuator_gain_scale": 1.0}


def _level(rows, factor, value):
    returns = [r["mean_return"] for r in rows if float(r[factor]) == float(value)]
    mean = sum(returns) / len(returns)
    var = sum((x - mean) ** 2 for x in returns) / max(len(returns) - 1, 1)
    return mean, math.sqrt(var / len(returns))


def render(data, **_):
    policies = data["policies"]
    names = list(policies)
    nominal = [
        r
        for r in policies["supervisor"]["rows"]
        if all(float(r[k]) == v for k, v in NOMINAL.items())
    ][0]["mean_return"]
    rows = [
        "| factor | value | " + " | ".join(f"{p} mean return (÷ nominal)" for p in names) + " |",
        "|---|---|" + "---|" * len(names),
    ]
    for factor, values in data["grid"].items():
        for value in values:
            cells = []
            for p in names:
                mean, se = _level(policies[p]["rows"], factor, value)
                cells.append(f"{mean:,.0f} ± {se:,.0f} ({mean / nominal:.2f})")
            rows.append(f"| `{factor}` | {value} | " + " | ".join(cells) + " |")
    overall = []
    for p in names:
        returns = [r["mean_return"] for r in policies[p]["rows"]]
        overall.append(
            f"{sum(returns) / len(returns):,.0f} ({sum(returns) / len(returns) / nominal:.2f})"
        )
    rows.append("| all | | " + " | ".join(overall) + " |")
    bc = policies["bc"]
    size = math.prod(len(v) for v in data["grid"].values())
    note = (
        f"`{data['env_id']}`: {size} configurations × {data['episodes']} episodes of up to 1,000 "
        f"steps (sweep seed {data['seed']}). Each level: the mean over the configurations with "
        "that value of their mean return ± its standard error over those configurations; in "
        "brackets, divided by the supervisor's mean return at the nominal configuration (every "
        f"scale 1: {nominal:,.0f}). BC: a decision tree on {bc['demonstrations']} supervisor "
        "demonstrations of the nominal configuration."
    )
    dagger = policies.get("dagger")
    if dagger:
        note += (
            f" DAgger: a decision tree, {dagger['initial_demos']} demonstration then "
            f"{dagger['iterations']} iterations of {dagger['rollouts_per_iteration']} on-policy "
            "rollouts labelled by the supervisor, on the same configuration."
        )
    note += f" Run time {data['seconds']:.0f} s on a {data['machine']}."
    return "\n".join(rows) + "\n\n" + note
