"""docs/results/fluids_curves.json (scripts/reproductions/fluids_learning_curves.py)."""


def render(data, **_):
    summary = data["summary"]
    algos = list(dict.fromkeys(e["algo"] for e in summary))
    demos = sorted({e["demonstrations"] for e in summary})
    cell = {(e["algo"], e["demonstrations"]): e for e in summary}
    s = data["settings"]
    head = "| demonstrations | " + " | ".join(f"{a} success" for a in algos)
    head += " | DART labels (train + noise) |" if "dart" in algos else " |"
    rows = [head, "|" + "---|" * (len(algos) + 1 + ("dart" in algos))]
    for n in demos:
        cells = []
        for a in algos:
            e = cell[(a, n)]
            cells.append(
                f"{e['success_rate']:.2f} ± {e['success_rate_se']:.2f} ({e['success_se_within_seed']:.2f})"
            )
        if "dart" in algos:
            e = cell[("dart", n)]
            cells.append(f"{e['training_labels']:,.0f} + {e['estimation_labels']:,.0f}")
        rows.append(f"| {n} | " + " | ".join(cells) + " |")
    return (
        "\n".join(rows)
        + f"\n\nSuccess rate on `{data['env_id']}`, mean over {s['seeds']} training seeds ± standard"
        f" error across seeds (in brackets: the evaluation episodes' own standard error, averaged"
        f" over seeds); {s['episodes']} evaluation episodes per point, episodes capped at"
        f" {s['max_steps']} steps, trees of depth {s['max_depth']}. The supervisor succeeds in"
        f" {data['supervisor_success_rate']:.0%} of the same episodes. Run time:"
        f" {data['seconds']:.0f} s."
    )
