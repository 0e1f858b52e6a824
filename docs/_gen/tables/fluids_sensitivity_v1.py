"""docs/results/fluids_sensitivity_v1.json (scripts/reproductions/fluids_sensitivity_v1.py's
`summary.json`): Fig. 7.6 on FLUIDS-Sensitivity-v1, its slices and ablations.

Parts: `"overview"` (in distribution and the full grid), `"marginals"` (the grid's marginal
success per parameter value, all configurations and the sighted half), `"slices"` (the
one-parameter slices around the training scene) and `"ablations"`.
"""

COMMAND = (
    "python scripts/reproductions/fluids_sensitivity_v1.py --out out/sensitivity_v1 --workers 2"
)
PARAMS = {
    "cars": "cars (ego included)",
    "pedestrians": "pedestrians",
    "lidar_noise": "quasi-LIDAR noise variance λ_l",
    "lidar_dropout": "omission probability ε",
    "lights": "lights (0 off, 1 on)",
    "car_mass": "car mass (kg)",
}
SLICES = {
    "slice_cars": "BC, cars",
    "slice_pedestrians": "BC, pedestrians",
    "slice_lidar_noise": "BC, noise λ_l",
    "slice_lidar_dropout": "BC, omission ε",
    "slice_lights": "BC, lights off / on (4 cars, 2 pedestrians)",
    "slice_lights_dense": "BC, lights off / on (5 cars, 4 pedestrians)",
    "slice_car_mass": "BC, car mass (kg)",
}
ABLATIONS = {
    "noise_trained": "BC trained with λ_l = 1, noise λ_l",
    "dropout_trained": "BC trained with ε = 0.5, omission ε",
    "supervisor_lights_dense": "supervisor, lights off / on (5 cars, 4 pedestrians)",
    "supervisor_mass": "supervisor, car mass (kg)",
}


def _value(v: str) -> str:
    f = float(v)
    return f"{f:g}"


def _points(points) -> str:
    pts = sorted(points, key=lambda p: float(p[0]))
    return ", ".join(f"{_value(v)}: **{s:.2f}**" for v, s, _ in pts)


def _runs(data, names: dict) -> str:
    runs = data["runs"]
    out = ["| run | success at each value (50 episodes a point unless noted) |", "|---|---|"]
    for tag, label in names.items():
        if tag in runs:
            n = {p[2] for p in runs[tag]["points"]}
            note = "" if n == {50} else f" ({'/'.join(map(str, sorted(n)))} episodes a point)"
            out.append(f"| {label} | {_points(runs[tag]['points'])}{note} |")
    return "\n".join(out)


def _footer(data) -> str:
    if "command" in data:
        return ""
    return f"\n\n<small>From `docs/results/fluids_sensitivity_v1.json`, the `summary.json` written by `{COMMAND}`.</small>"


def render(data, part: str = "overview", **_) -> str:
    if part == "overview":
        main = data["main"]
        ind = data.get("in_distribution", {})
        blind = dict((v, s) for v, s, _ in main["marginals"]["lidar_dropout"])
        out = ["| run | episodes | success |", "|---|---|---|"]
        for tag, label in (
            ("main", "BC in distribution (held-out seeds)"),
            ("noise_trained", "BC trained with λ_l = 1, in distribution"),
            ("dropout_trained", "BC trained with ε = 0.5, in distribution"),
        ):
            r = ind.get(tag)
            if r:
                out.append(
                    f"| {label} | {r['episodes']} | {r['successes']}/{r['episodes']} "
                    f"({r['collisions']} failures before the limit, {r['timeouts']} timeouts) |"
                )
        out += [
            f"| full grid, {main['configurations']} configurations | {main['episodes']} | "
            f"{main['success']:.3f} |",
            f"| sighted half (ε = 0) | {main['episodes'] // 2} | {main['sighted_success']:.3f} |",
            f"| blind half (ε = 1) | {main['episodes'] // 2} | {blind['1.0']:.3f} |",
        ]
        return "\n".join(out) + _footer(data)
    if part == "marginals":
        main = data["main"]
        out = [
            "| parameter | all configurations | sighted half (ε = 0) |",
            "|---|---|---|",
        ]
        for k, label in PARAMS.items():
            allm = _points(main["marginals"][k])
            sighted = main["sighted_marginals"].get(k)
            out.append(f"| {label} | {allm} | {_points(sighted) if sighted else '–'} |")
        return "\n".join(out) + _footer(data)
    if part == "slices":
        return _runs(data, SLICES) + _footer(data)
    if part == "ablations":
        return _runs(data, ABLATIONS) + _footer(data)
    raise ValueError(f"unknown part {part!r}")
