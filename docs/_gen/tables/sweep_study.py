"""docs/results/sweep_{singulation,track,grasping,fluids}.json (scripts/reproductions/sensitivity_study.py --tasks ...)."""


def _cell(entry, metric):
    text = f"{entry['metric']:.2f} ± {entry['stderr']:.2f}"
    if metric == "return":
        text += f" ({entry['mean_return']:,.0f})"
    return text


def render(data, **_):
    metric = data["metric"]
    policies = data["policies"]
    names = list(policies)
    what = "success rate" if metric == "success" else "normalised return (mean return)"
    rows = [
        "| factor | value | " + " | ".join(f"{p} {what}" for p in names) + " |",
        "|---|---|" + "---|" * len(names),
    ]
    for factor in data["grid"]:
        levels = {p: policies[p]["summary"]["factors"][factor] for p in names}
        for i, value in enumerate(data["grid"][factor]):
            cells = [_cell(levels[p][i], metric) for p in names]
            rows.append(f"| `{factor}` | {value} | " + " | ".join(cells) + " |")
    overall = " | ".join(f"{policies[p]['summary']['overall']:.2f}" for p in names)
    rows.append(f"| all | | {overall} |")
    bc = policies.get("bc", {})
    fixed = ", ".join(f"`{k}={v}`" for k, v in data["fixed_kwargs"].items()) or "none"
    size = 1
    for values in data["grid"].values():
        size *= len(values)
    note = (
        f"`{data['env_id']}` (fixed kwargs: {fixed}); {size} configurations × "
        f"{data['episodes']} episodes"
        + (f" of up to {data['max_episode_steps']} steps" if data.get("max_episode_steps") else "")
        + f" (sweep seed {data['seed']}); each level pools the "
        f"configurations with that value (± standard error"
    )
    if metric == "success":
        note += " of the pooled episodes)."
    else:
        note += (
            " over configurations); a configuration's mean return is divided by the largest "
            "absolute mean return of that policy's sweep."
        )
    if bc:
        note += (
            f" BC: a decision tree on {bc['demonstrations']} supervisor demonstrations of the "
            "nominal configuration (the registered defaults)."
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
