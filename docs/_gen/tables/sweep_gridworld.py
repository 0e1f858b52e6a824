"""docs/results/sweep_gridworld.json (scripts/reproductions/sensitivity_study.py --tasks gridworld)."""

import math

from fluids_bench.sweep.compare import level_stats, nominal_row
from fluids_bench.sweep.grid import KwargGrid


def render(data, at=None, **_):
    """The levels of every factor; `at="size"`: only the configurations with that factor at
    its nominal value (the other factors' levels in the trained world)."""
    policies = data["policies"]
    names = list(policies)
    reference = nominal_row(policies["supervisor"]["rows"], data["nominal"])["mean_return"]
    factors = {k: tuple(v) for k, v in data["grid"].items() if k != at}
    grid = KwargGrid(factors)
    chosen = {
        p: [
            r
            for r in policies[p]["rows"]
            if at is None or float(r[at]) == float(data["nominal"][at])
        ]
        for p in names
    }
    stats = {p: level_stats(chosen[p], grid, "return") for p in names}
    rows = [
        "| factor | value | " + " | ".join(f"{p} mean return (÷ reference)" for p in names) + " |",
        "|---|---|" + "---|" * len(names),
    ]
    for factor, values in factors.items():
        for i, value in enumerate(values):
            cells = []
            for p in names:
                e = stats[p][factor][i]
                cells.append(
                    f"{e['metric']:.0f} ± {e['stderr']:.0f} "
                    f"({e['metric'] / reference:.2f} ± {e['stderr'] / reference:.2f})"
                )
            mark = " (nominal)" if value == data["nominal"][factor] else ""
            rows.append(f"| `{factor}` | {value}{mark} | " + " | ".join(cells) + " |")
    if at is not None:
        return "\n".join(rows) + (
            f"\n\nOnly the configurations with `{at}={data['nominal'][at]}` (the trained "
            "value), each level pooling those with that value; errors and reference as above."
        )
    overall = []
    for p in names:
        returns = [r["mean_return"] for r in policies[p]["rows"]]
        mean = sum(returns) / len(returns)
        overall.append(f"{mean:.0f} ({mean / reference:.2f})")
    rows.append("| all | | " + " | ".join(overall) + " |")
    at_nominal = " | ".join(
        f"{nominal_row(policies[p]['rows'], data['nominal'])['mean_return']:.0f}" for p in names
    )
    rows.append(f"| nominal configuration | | {at_nominal} |")
    bc, dagger = policies["bc"], policies["dagger"]
    size = math.prod(len(v) for v in data["grid"].values())
    nominal = ", ".join(f"`{k}={v}`" for k, v in data["nominal"].items())
    note = (
        f"`{data['env_id']}`: {size} configurations × {data['episodes']} episodes of 30 steps "
        f"(sweep seed {data['seed']}). Each level: the mean over the configurations with that "
        "value of their mean return ± its standard error (the episodes' sampling error, "
        "sqrt(Σ s_i²/n_i)/k over the k configurations); in brackets, divided by the "
        f"reference: the supervisor's mean return at the nominal configuration ({nominal}: "
        f"{reference:.0f}). BC: a decision tree on {bc['demonstrations']} supervisor "
        "demonstrations of the nominal configuration. DAgger: a decision tree, "
        f"{dagger['initial_demos']} demonstration then {dagger['iterations']} iterations of "
        f"{dagger['rollouts_per_iteration']} on-policy rollouts labelled by the supervisor, on "
        f"the same configuration. Run time {data['seconds']:.0f} s on a {data['machine']}."
    )
    return "\n".join(rows) + "\n\n" + note
