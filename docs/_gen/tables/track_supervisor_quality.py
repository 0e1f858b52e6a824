"""Renderer of docs/results/track_supervisor_quality.json (crashes per lap of the DrivingTrack
search supervisor by look-ahead depth, with and without action noise)."""

from __future__ import annotations

DEFAULT_DEPTH = 8
SOURCE_LIKE_DEPTH = 1


def render(data: dict, **options) -> str:
    by = {(r["depth"], r["noise"]): r for r in data["rows"]}
    noises = sorted({r["noise"] for r in data["rows"]})
    noisy = [n for n in noises if n > 0]

    def name(n: float) -> str:
        return "" if n == 0 else f", {100 * n:g}% noise"

    head = "| depth | " + " | ".join(f"crashes/lap{name(n)}" for n in noises)
    head += " | " + " | ".join(f"laps without a crash{name(n)}" for n in noises)
    head += " | µs per step (CPU) |"
    lines = [head, "|---|" + "---|" * (2 * len(noises) + 1)]
    for depth in sorted({r["depth"] for r in data["rows"]}):
        label = str(depth)
        if depth == SOURCE_LIKE_DEPTH:
            label += " (`DrivingTrack-Source-v0`)"
        elif depth == DEFAULT_DEPTH:
            label += " (default)"
        cells = [
            f"{by[depth, n]['crashes_per_lap']:.2f}" if (depth, n) in by else "" for n in noises
        ]
        cells += [
            f"{100 * by[depth, n]['clean_lap_share']:.1f}%" if (depth, n) in by else ""
            for n in noises
        ]
        lines.append(
            f"| {label} | "
            + " | ".join(cells)
            + f" | {by[depth, noises[0]]['cpu_us_per_step']:.0f} |"
        )
    lines += [
        "",
        f"One two-lap episode on each of {data['tracks']} tracks ({data['seeds']}); "
        f"noise p: {data['noise']}"
        + (f" (p = {', '.join(f'{n:g}' for n in noisy)})" if noisy else "")
        + f"; state observation; µs per step without noise, supervisor and env together; "
        f"{data['machine']}. The source's supervisor: {data['source_crashes_per_lap']:g} crashes per lap.",
    ]
    return "\n".join(lines)
