"""docs/results/client_d3rlpy.json (scripts/clients/d3rlpy_bc.py)."""


def render(data, **_):
    mean = data["mean_return"]
    rows = ["| policy | mean return |", "|---|---|"]
    rows += [f"| {name} | {mean[name]:,.1f} |" for name in ("bc", "random", "supervisor")]
    v = data["versions"]
    return (
        "\n".join(rows) + f"\n\n`{data['env']}`: d3rlpy {v['d3rlpy']} BC trained for"
        f" {data['bc_steps']:,} steps on {data['episodes']} supervisor episodes"
        f" ({data['transitions']:,} transitions) loaded by `get_minari`, evaluated on seeds"
        f" {data['eval_seeds'][0]}–{data['eval_seeds'][1]} (held out); Gymnasium"
        f" {v['gymnasium']}, Minari {v['minari']}. BC beats random:"
        f" {'yes' if data['bc_beats_random'] else 'no'}. Machine: {data['machine']}."
        f" Command: `{data['command']}`."
    )
