"""Fig. 7.6 on FLUIDS-Sensitivity-v1, with the slices and ablations the README's comparison uses.

Every run is a ``fluids-bench sweep`` in its own folder under ``--out`` (each resumable, so
rerunning this script after an interruption continues where it stopped):

* ``main``: the six parameters of the source, car mass with the in-distribution 1500 kg
  between the two mismatched ends (384 configurations x ``--episodes``); BC (a decision tree
  on 100 supervisor demonstrations) and its in-distribution check (100 held-out seeds);
* ``slice_<name>``: one parameter varied around the training scene (4 cars, 2 pedestrians,
  no noise, no omission, lights on, 1500 kg), the others fixed, ``--slice-episodes`` a point,
  the main sweep's policy; ``slice_lights_dense`` the same at 5 cars and 4 pedestrians;
* ablations: ``noise_trained`` / ``dropout_trained`` (BC trained with λ_l = 1 / ε = 0.5, on
  the noise / omission slice), ``supervisor_lights_dense`` and ``supervisor_mass`` (the
  supervisor itself on the lights and mass slices).

Then ``summary.json`` (success per point of every run; the main sweep's marginals over all
configurations and over its sighted half, ε = 0) and a Markdown digest on stdout.

    python scripts/reproductions/fluids_sensitivity_v1.py --out out/sensitivity_v1 --workers 2
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from pathlib import Path

from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.provenance import announce

ENV = "FLUIDS-Sensitivity-v1"
BASE = {
    "cars": "4",
    "pedestrians": "2",
    "lidar_noise": "0",
    "lidar_dropout": "0",
    "lights": "on",
    "car_mass": "1500",
}
DENSE = {**BASE, "cars": "5", "pedestrians": "4"}
SLICES = {
    "cars": "2,3,4,5",
    "pedestrians": "0,1,2,3,4",
    "lidar_noise": "0,0.25,0.5,1,2",
    "lidar_dropout": "0,0.25,0.5,0.75,0.9,1",
    "lights": "off,on",
    "car_mass": "750,1125,1500,2250,3000",
}


def sweep(out: Path, args, values: dict[str, str], *extra: str) -> None:
    cmd = [sys.executable, "-m", "fluids_bench.cli", "sweep", "--env", ENV, "--out", str(out)]
    for name, vals in values.items():
        cmd += ["--values", f"{name}={vals}"]
    cmd += ["--workers", str(args.workers), *extra]
    print("$", " ".join(cmd[2:]), flush=True)
    subprocess.run(cmd, check=True)


def rows(folder: Path) -> list[dict]:
    with open(folder / "results.csv", newline="") as f:
        return list(csv.DictReader(f))


def points(chosen: list[dict], name: str) -> list[tuple[str, float, int]]:
    """(value, success rate, episodes) of ``name`` over the rows ``chosen``."""
    out = []
    for value in dict.fromkeys(r[name] for r in chosen):
        sel = [r for r in chosen if r[name] == value]
        n = sum(int(r["episodes"]) for r in sel)
        out.append((value, sum(int(r["successes"]) for r in sel) / n, n))
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/sensitivity_v1"))
    p.add_argument("--episodes", type=int, default=20, help="per configuration, main sweep")
    p.add_argument("--slice-episodes", type=int, default=50, help="per point, slices")
    p.add_argument("--workers", type=int, default=2)
    args = p.parse_args()
    announce("~7 min on 2 free cores for the main sweep; the slices and ablations add more")
    out = args.out
    main_dir = out / "main"
    sweep(
        main_dir,
        args,
        {"car_mass": "750,1500,3000"},
        "--check-episodes", "100", "--episodes", str(args.episodes),
    )  # fmt: skip
    policy = str(main_dir / "policy.pkl")
    n = str(args.slice_episodes)
    runs: dict[str, tuple[Path, str]] = {}
    for name, vals in SLICES.items():
        runs[f"slice_{name}"] = (out / f"slice_{name}", name)
        sweep(
            out / f"slice_{name}", args, {**BASE, name: vals}, "--policy", policy, "--episodes", n
        )
    runs["slice_lights_dense"] = (out / "slice_lights_dense", "lights")
    sweep(runs["slice_lights_dense"][0], args, {**DENSE, "lights": "off,on"}, "--policy", policy,
          "--episodes", n)  # fmt: skip
    for tag, kwarg, name in (
        ("noise_trained", "lidar_noise=1", "lidar_noise"),
        ("dropout_trained", "lidar_dropout=0.5", "lidar_dropout"),
    ):
        runs[tag] = (out / tag, name)
        sweep(out / tag, args, {**BASE, name: SLICES[name]}, "--train-kwarg", kwarg,
              "--check-episodes", n, "--episodes", n)  # fmt: skip
    runs["supervisor_lights_dense"] = (out / "supervisor_lights_dense", "lights")
    sweep(runs["supervisor_lights_dense"][0], args, {**DENSE, "lights": "off,on"},
          "--policy", "supervisor", "--episodes", n)  # fmt: skip
    runs["supervisor_mass"] = (out / "supervisor_mass", "car_mass")
    sweep(runs["supervisor_mass"][0], args, {**BASE, "car_mass": SLICES["car_mass"]},
          "--policy", "supervisor", "--episodes", n)  # fmt: skip

    main_rows = rows(main_dir)
    sighted = [r for r in main_rows if float(r["lidar_dropout"]) == 0.0]
    summary = {
        "command": "python scripts/reproductions/fluids_sensitivity_v1.py "
        + " ".join(sys.argv[1:]),
        "env": ENV,
        "main": {
            "configurations": len(main_rows),
            "episodes": sum(int(r["episodes"]) for r in main_rows),
            "success": sum(int(r["successes"]) for r in main_rows)
            / sum(int(r["episodes"]) for r in main_rows),
            "sighted_success": sum(int(r["successes"]) for r in sighted)
            / sum(int(r["episodes"]) for r in sighted),
            "marginals": {k: points(main_rows, k) for k in SLICES},
            "sighted_marginals": {k: points(sighted, k) for k in SLICES if k != "lidar_dropout"},
        },
        "runs": {
            tag: {"parameter": name, "points": points(rows(d), name)}
            for tag, (d, name) in runs.items()
        },
    }
    for tag in ("main", "noise_trained", "dropout_trained"):
        info = out / ("main" if tag == "main" else tag) / "policy.json"
        if info.exists():
            summary.setdefault("in_distribution", {})[tag] = json.loads(info.read_text()).get(
                "in_distribution"
            )
    write_json_atomic(out / "summary.json", summary)
    print(f"\nmain: {summary['main']['episodes']} episodes, success {summary['main']['success']:.3f}"
          f", sighted half {summary['main']['sighted_success']:.3f}")  # fmt: skip
    print("in distribution:", json.dumps(summary.get("in_distribution")))
    for tag, run in summary["runs"].items():
        line = ", ".join(f"{v}: {s:.2f}" for v, s, _ in run["points"])
        print(f"- {tag} ({run['parameter']}): {line}")
    for k, pts in summary["main"]["sighted_marginals"].items():
        print(f"- sighted marginal {k}: " + ", ".join(f"{v}: {s:.3f}" for v, s, _ in pts))


if __name__ == "__main__":
    main()
