"""Renderer of docs/results/reproduce_dag.json (Theorem 1 on DAG-v0).

Parts: `"on_policy"` (default: how often DAgger ends at R against m, with the bound) and
`"off_policy"` (how often Behavior Cloning ends at L against N).
"""

from __future__ import annotations


def _pct(x: float) -> str:
    return f"{100 * x:.2f}%"


def on_policy(data: dict) -> str:
    lines = [
        "| m (initial demos) | runs | ended at R | 95% interval | exact P(first vote is R) | c·e^−m | bound holds |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in data["on_policy"]:
        lo, hi = r["end_r_wilson_95"]
        lines.append(
            f"| {r['m']} | {r['runs']:,} | {_pct(r['end_r_frequency'])} | {_pct(lo)}–{_pct(hi)} "
            f"| {_pct(r['exact_first_vote_r'])} | {_pct(r['c_exp_minus_m'])} | {'yes' if r['bound_holds'] else '**no**'} |"
        )
    s = data["settings"]
    lines += [
        "",
        f"μ = {s['mu']:g}, {s['iterations']} on-policy iterations per run, c = {data['c']:.3f} (the largest c "
        f"keeping c·e^−m under the exact probability for m ≤ {s['max_m']}); 95% Wilson intervals; "
        f"{data['seconds']:.0f} s wall with {s['workers']} worker(s) on {data['machine']}.",
    ]
    return "\n".join(lines)


def off_policy(data: dict) -> str:
    lines = [
        "| N (demonstrations) | runs | ended at L | exact P(majority is L) |",
        "|---|---|---|---|",
    ]
    for r in data["off_policy"]:
        lines.append(
            f"| {r['n']} | {r['runs']:,} | {_pct(r['end_l_frequency'])} | {_pct(1 - r['exact_end_r'])} |"
        )
    e = data["expected_returns"]
    lines += [
        "",
        f"Expected returns: supervisor {e['supervisor']:g}, constant L {e['L']:g}, constant R {e['R']:g}.",
    ]
    return "\n".join(lines)


def render(data: dict, part: str = "on_policy", **options) -> str:
    parts = {"on_policy": on_policy, "off_policy": off_policy}
    if part not in parts:
        raise ValueError(f"part is {part!r}; allowed: {sorted(parts)}")
    return parts[part](data)
