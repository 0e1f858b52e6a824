"""Renderer of docs/results/dart_mujoco_*.json (Fig. 3.3 and 3.4, every task and setting).

The DART-on-MuJoCo files share one layout (written by scripts/reproductions/reproduce_dart_mujoco.py),
so the other dart_mujoco_* renderers reuse this one's `render`.
"""

from __future__ import annotations

METHODS = {
    "bc": "BC",
    "dagger": "DAgger",
    "dagger_b": "DAgger-B",
    "isotropic": "isotropic Σ = I",
    "dart": "DART",
    "dart_fixed": "DART, Σ̂ rescaled to trace {trace:g} (ablation)",
    "dart_literal": "DART, α = T·tr(Σ̂) literally (T = {T})",
}
LEARNERS = ("mlp", "linear")


def _n(x: float) -> str:
    return f"{x:,.0f}"


def _seconds(x: float) -> str:
    return f"{x:.1f}" if x < 10 else f"{x:,.0f}"


def _supervisor(row: dict) -> str:
    record = row.get("supervisor")
    if not record:
        return "the shipped policy, weights not recorded in this file"
    if "weights_sha256" in record:
        return f"{record['kind']}, weights sha256 {record['weights_sha256'][:12]}…"
    return record["kind"]


def _noisy_window(settings: dict) -> int | None:
    """Index of the first collection after DART's first noise estimate (iteration k + 1 for
    an estimate after iteration k); None for schedules with initial demonstrations."""
    if settings.get("initial_demos"):
        return None
    return settings.get("update_every") or settings["update_at"][0]


def render(data: dict, **options) -> str:
    settings = data["settings"]
    summary = data["summary"]
    rows = []
    for key, s in summary.items():
        _, learner, method = key.split("/")
        rows.append((LEARNERS.index(learner), list(METHODS).index(method), learner, method, s))
    rows.sort()
    eval_at = rows[0][4]["eval_iterations"]
    head = "| learner / method | " + " | ".join(f"iter {i}" for i in eval_at)
    first = _noisy_window(settings)
    head += " | mean collection return |"
    if first is not None:
        head += f" collection from iter {first + 1}, % of supervisor |"
    # the noise each run injected (files written before the runs recorded it have no column)
    traces = any(any(v is not None for v in r[4].get("noise_trace_mean", [])) for r in rows)
    if traces:
        head += " injected tr(Σ), mean |"
    head += " fit seconds |"
    lines = [head, "|---|" + "---|" * (len(eval_at) + 2 + (first is not None) + traces)]
    for _, _, learner, method, s in rows:
        name = METHODS[method].format(
            trace=settings.get("dart_fixed_trace", 0.0), T=settings["eval_steps"]
        )
        cells = [
            f"{_n(m)} ± {_n(e)}"
            for m, e in zip(s["eval_return_mean"], s["eval_return_se"], strict=True)
        ]
        collection = sum(s["collection_return_mean"]) / len(s["collection_return_mean"])
        share = ""
        collected = s["collection_return_mean"]
        # the iteration of each record (DAgger's first is iteration 0: its initial demonstration)
        its = s.get("collection_iterations") or list(
            range(settings["iterations"] + 1 - len(collected), settings["iterations"] + 1)
        )
        if first is not None:
            late = [c for i, c in zip(its, collected, strict=True) if i > first]
            share = f" {100 * sum(late) / len(late) / s['supervisor_return_mean']:.0f} % |"
        injected = ""
        if traces:
            # a record's trace is the noise of the next iteration's rollouts: those from
            # iteration first + 1 on (the share column's) were collected under records first..-1
            recorded = zip(its, s.get("noise_trace_mean", []), strict=True)
            values = [
                v
                for i, v in recorded
                if v is not None and (first or 0) <= i < settings["iterations"]
            ]
            injected = f" {sum(values) / len(values):.3g} |" if values else " – |"
        lines.append(
            f"| {'MLP' if learner == 'mlp' else 'linear'} / {name} | "
            + " | ".join(cells)
            + f" | {_n(collection)} |{share}{injected} {_seconds(s['train_seconds_total_mean'])} |"
        )
    first_row = rows[0][4]
    lines.append("")
    lines.append(
        f"Mean evaluation return ± standard error over {first_row['seeds']} seeds "
        f"({settings['eval_episodes']} seeded episodes of {settings['eval_steps']} steps per point); "
        f"the supervisor scores {_n(first_row['supervisor_return_mean'])} over {settings['eval_steps']} steps. "
        "Mean collection return: the reward of the rollouts each method collected, over all iterations"
        + (
            f"; from iteration {first + 1} (after DART's first noise estimate), as a share of the "
            "supervisor's. "
            if first is not None
            else ". "
        )
        + (
            "Injected tr(Σ): the trace of the noise covariance those rollouts were collected "
            "under, mean over them and the seeds. "
            if traces
            else ""
        )
        + f"Supervisor: {_supervisor(first_row)}. "
        "Fit seconds: total time fitting the learner (cumulative `train_seconds`, mean over seeds)."
    )
    return "\n".join(lines)
