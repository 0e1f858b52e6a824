"""Renderer of docs/results/reproduce_track_shiv.json (the driving-track SHIV experiments).

Parts: `"fig63"` (SHIV vs DAgger), `"fig65"` (false negatives of the query selectors) and
`"table61"` (SHIV's sensitivity to sigma, next to the source's Table 6.1). Values in the file
are `[mean, standard error]` over tracks.
"""

from __future__ import annotations

# the source's Table 6.1: sigma -> (crashes, states labelled)
SOURCE_TABLE61 = {
    1: (5.8, 4122),
    50: (5.7, 3864),
    150: (5.9, 1859),
    200: (6.1, 1524),
    250: (6.3, 1536),
    350: (13.2, 521),
}
SELECTORS = {
    "confidence": "confidence (distance to hyperplane)",
    "qbc": "query by committee",
    "mmd": "MMD",
    "novelty": "One-Class SVM",
    "shiv": "SHIV",
}


def fig63(data: dict) -> str:
    f = data["fig63"]
    curves = f["curves"]
    n = len(curves["dagger"]["labels"])
    lines = [
        "| iteration | " + " | ".join(str(i) for i in range(n)) + " |",
        "|---|" + "---|" * n,
    ]
    for algo, name in (("dagger", "DAgger"), ("shiv", "SHIV")):
        c = curves[algo]
        lines.append(
            f"| {name}: states labelled | " + " | ".join(f"{x:,.0f}" for x in c["labels"]) + " |"
        )
        lines.append(
            f"| {name}: crashes/lap ÷ supervisor's | "
            + " | ".join(
                f"{m:.2f} ± {e:.2f}"
                for m, e in zip(c["normalised"], c["normalised_se"], strict=True)
            )
            + " |"
        )
    d, s = curves["dagger"], curves["shiv"]
    lines += [
        "",
        f"Mean ± standard error over {d['tracks']} tracks; the supervisor: {d['supervisor_crashes_per_lap']:.2f} "
        f"crashes per lap on these evaluation starts; the learners end at {d['crashes_per_lap'][-1]:.2f} (DAgger) "
        f"and {s['crashes_per_lap'][-1]:.2f} (SHIV). At the best level both reach ({f['level']:.2f} × the "
        f"supervisor's), SHIV needed {f['labels_to_reach']['shiv']:,.0f} labels and DAgger "
        f"{f['labels_to_reach']['dagger']:,.0f}: **{100 * f['reduction']:.0f}% fewer**; after the last "
        f"iteration SHIV has labelled {100 * f['final_label_share']:.0f}% of DAgger's states.",
    ]
    return "\n".join(lines)


def fig65(data: dict) -> str:
    f = data["fig65"]
    lines = [
        "| selector | truly risky states called safe | share of all rollout states asked |",
        "|---|---|---|",
    ]
    for key, name in SELECTORS.items():
        fn, asked = f[key]["false_negative_share"], f[key]["marked_risky_share"]
        missed = "–" if fn is None else f"{100 * fn[0]:.1f}% ± {100 * fn[1]:.1f}"
        lines.append(f"| {name} | {missed} | {100 * asked[0]:.1f}% |")
    risky = f["mean_truly_risky"]
    lines += [
        "",
        f"{f['tracks']} tracks; means ± standard errors over the tracks (false negatives: over those "
        f"with at least one truly risky state); {risky[0]:.1f} ± {risky[1]:.1f} truly risky states "
        "per first rollout.",
    ]
    return "\n".join(lines)


def table61(data: dict) -> str:
    t = data["table61"]
    raw = "raw" in data["settings"]["shiv"]["sigma_units"].lower()
    head = "| σ | source: crashes | source: states labelled | here: crashes per lap | here: states labelled |"
    if raw:
        head = "| σ (raw HOG units) | crashes per lap | states labelled |"
    lines = [head, "|---|---|---|---|---|" if not raw else "|---|---|---|"]
    for key in sorted(t, key=float):
        r = t[key]
        sigma = float(key)
        crash, labels = r["crashes_per_lap"], r["states_labelled"]
        here = f"{crash[0]:.2f} ± {crash[1]:.2f} | {labels[0]:,.0f} ± {labels[1]:,.0f}"
        if raw:
            lines.append(f"| {sigma:g} | {here} |")
        else:
            source = SOURCE_TABLE61.get(int(sigma)) if sigma.is_integer() else None
            src = f"{source[0]:g} | {source[1]:,}" if source else "– | –"
            lines.append(f"| {sigma:g} (× m / 200) | {src} | {here} |")
    sup = next(iter(t.values()))["supervisor_crashes_per_lap"]
    lines += [
        "",
        f"After {data['settings']['iterations']} iteration(s), mean ± standard error over "
        f"{next(iter(t.values()))['tracks']} tracks; σ_r = 200; the supervisor: {sup[0]:.2f} ± {sup[1]:.2f} "
        "crashes per lap on the evaluation starts"
        + (
            "."
            if raw
            else "; m = the track's median HOG distance between a demonstration's distinct states."
        ),
    ]
    return "\n".join(lines)


def render(data: dict, part: str = "fig63", **options) -> str:
    parts = {"fig63": fig63, "fig65": fig65, "table61": table61}
    if part not in parts:
        raise ValueError(f"part is {part!r}; allowed: {sorted(parts)}")
    if data.get(part) is None:
        raise ValueError(
            f"docs/results/reproduce_track_shiv.json has no {part!r} (run that experiment)"
        )
    return parts[part](data)
