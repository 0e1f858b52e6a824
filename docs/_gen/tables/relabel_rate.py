"""docs/results/relabel_rate.json (scripts/benchmarks/bench_relabel.py)."""


def render(data, **_):
    rows = [
        "| env | kwargs | states labelled | seconds | labels per minute |",
        "|---|---|---|---|---|",
    ]
    for t in data["tasks"]:
        kwargs = ", ".join(f"{k}={v}" for k, v in t["env_kwargs"].items()) or "(defaults)"
        rows.append(
            f"| `{t['env_id']}` | {kwargs} | {t['labels']} | {t['seconds']:.2f} |"
            f" {t['labels_per_minute']:,.0f} |"
        )
    s = data["settings"]
    return (
        "\n".join(rows) + f"\n\nOne scripted relabelling session per task in a real pygame window"
        f" (SDL video driver `{s['video_driver']}`), one confirming input posted as soon as each"
        f" state is drawn; the episode was teleoperated by the simulated person with states"
        f" stored every {s['snapshot_every']} steps (the others replayed). Machine:"
        f" {data['machine']}. Command: `{data['command']}`."
    )
