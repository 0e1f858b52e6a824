"""Renderer of docs/results/reproduce_grasping_shiv.json (Fig. 6.4: SHIV vs DAgger vs Behavior
Cloning on grasping in clutter). The ablations' files (`reproduce_grasping_shiv_<suffix>.json`)
have the same layout and share this renderer."""

from __future__ import annotations

NAMES = {"dagger": "DAgger", "shiv": "SHIV", "bc": "BC (one demonstration per iteration)"}


def render(data: dict, iterations: tuple[int, ...] = (1, 5, 10), **options) -> str:
    summary = {k: v for k, v in data["summary"].items() if k in NAMES}
    settings = data["settings"]
    shown = [i for i in iterations if i <= settings["iterations"]]
    lines = [
        "| learner | 1 demo | "
        + " | ".join(f"iteration {i}" for i in shown)
        + " | cost at the end | queries at the end |",
        "|---|---|" + "---|" * len(shown) + "---|---|",
    ]
    for algo in [a for a in NAMES if a in summary]:
        s = summary[algo]
        mean, se = s["normalised_mean"], s["normalised_stderr"]
        cells = [f"{mean[0]:.2f}"]
        for i in shown:
            cell = f"{mean[i]:.2f}"
            if i == shown[-1] and se:
                cell += f" ± {se[i]:.2f}"
            cells.append(cell)
        lines.append(
            f"| {NAMES[algo]} | "
            + " | ".join(cells)
            + f" | {s['cost_mean'][-1]:.2f} | {s['labels'][-1]:,.0f} |"
        )
    policy = settings["policy"]
    shiv = settings["shiv"]
    lines += [
        "",
        f"Normalised performance (1 = the supervisor on the same seeds), mean over {settings['rounds']} rounds "
        f"(± standard error at the end); kernel ridge {policy['params']} on "
        f"{'standardised' if policy['standardize'] else 'raw'} features; SHIV σ = {shiv['sigma']}, "
        f"σ_r = {shiv['sigma_r']}; labels per rollout: {settings['samples_per_demo'] or 'all'}; "
        f"{settings['eval_episodes']} evaluation episodes per iteration; {data['machine']}.",
    ]
    # levels at which one of the two never arrives have no reduction (null)
    reduction = {
        k: v for k, v in (data["summary"].get("query_reduction") or {}).items() if v is not None
    }
    if reduction:
        lines.append(
            "SHIV's query reduction at the levels both reach: "
            + ", ".join(
                f"{float(k):g}: {100 * v:.1f}%"
                for k, v in sorted(reduction.items(), key=lambda kv: float(kv[0]))
            )
            + "."
        )
    return "\n".join(lines)
