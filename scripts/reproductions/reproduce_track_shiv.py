"""Reproduce the source's ch. 6 driving-track experiments: Fig. 6.3, Fig. 6.5 and Table 6.1.

All on DrivingTrack-Source-v0 (the imperfect depth-1 search supervisor), HOG observations, a
linear SVM policy with slack penalty C = 0.01 (the source's "gamma = 0.01 ... on the slack
variables"), one track per run (``track_seed`` = run index), with the algorithm layer
(``fluids_bench.algos``: ``dagger``, ``shiv``, ``query``).

The linear SVM is ``linear_svm_span``: LinearSVC's problem (standardised features, squared
hinge, one-vs-rest) solved in the span of the distinct training states, which gives the same
model as ``linear_svm`` (decision values equal to the solver's tolerance) about 50x faster on
20,736 HOG dimensions; ``max_iter`` is raised so that it converges (scikit-learn's default
1,000 passes did not, on the full features). The baselines' SVMs (confidence, committee) are
the same model.

Bandwidths are the source's values mapped to this HOG's scale
(:mod:`fluids_bench.tasks.track.bandwidth`): sigma = sigma_source / 200 x the median distance
between the distinct states of a supervisor demonstration on the track. Every sigma below is in
the source's units.

- ``fig63``: DAgger (beta = 0) vs SHIV (sigma = sigma_r = 200, nu = 0.1, nu_r = 1e-3), one
  initial two-lap supervisor demonstration, 6 iterations of one rollout each, all visited
  states of a rollout are candidates (no subsampling). Performance is crashes per lap of the
  learner divided by the supervisor's on the same evaluation starts (1 = the supervisor; lower
  is better), against the states labelled; also the query reduction of SHIV at the level both
  reach.
- ``fig65``: the query selectors of ``algos.query`` (confidence, query-by-committee, MMD,
  plain One-Class SVM = ``novelty``, SHIV) fit on two supervisor demonstrations D0 and the
  policy trained on them; during the first policy rollout, the share of truly risky states
  (where that policy's action differs from the supervisor's label) each one marks safe
  (false negatives).
- ``table61``: SHIV with sigma in {1, 50, 150, 200, 250, 350} (sigma_r = 200): crashes per lap
  of the final policy and states labelled after 6 iterations. Its sigma = 200 runs are Fig.
  6.3's SHIV runs (same configuration and seed), computed once.

Every SHIV parameter is passed explicitly (nothing relies on the layer's defaults).

Each (experiment, track, method) is one unit whose result is written atomically to
``--out/units/<key>.json``; a rerun skips finished units, so a killed run resumes. Units run on
``--workers`` processes with a progress bar. The summaries (``track_shiv.json``) and plots
(``--images``) are rebuilt from whatever units exist.

Usage: ``python scripts/reproductions/reproduce_track_shiv.py --workers 2`` (the source's size: 40, 50 and
40 tracks, about 2,600 CPU-s); ``--tracks N`` caps every experiment at N tracks. Also writes the
results file the docs read (``--results``, default ``docs/results/reproduce_track_shiv.json``,
or ``reproduce_track_shiv_raw_sigma.json`` with ``--raw-sigma``): the command line and the
summary.
"""

from __future__ import annotations

import argparse
import functools
import json
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fluids_bench.algos import dagger, shiv
from fluids_bench.algos.actors import SUPERVISOR, LearnerActor
from fluids_bench.algos.harness import SEED_BOUND, make_env
from fluids_bench.algos.plots import new_figure, save_png_atomic
from fluids_bench.algos.policies import PolicySpec, fit_policy
from fluids_bench.algos.query import (
    CommitteeSelector,
    ConfidenceSelector,
    MMDSelector,
    NoveltySelector,
    ShivSelector,
)
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.algos.rollout import rollout
from fluids_bench.core.parallel import one_blas_thread
from fluids_bench.core.provenance import command_line, machine
from fluids_bench.tasks.track.bandwidth import median_state_distance, source_sigma

REPO = Path(__file__).resolve().parents[2]
CPU_SECONDS_PER_UNIT = 8.0  # measured: 322 units at the source's size took 2,578 CPU-s


ENV_ID = "DrivingTrack-Source-v0"
POLICY = PolicySpec("linear_svm_span", {"C": 0.01, "max_iter": 10_000})
NU, NU_R, SIGMA, SIGMA_R = 0.1, 1e-3, 200.0, 200.0
TABLE_SIGMAS = (1.0, 50.0, 150.0, 200.0, 250.0, 350.0)
SELECTOR_NAMES = ("confidence", "qbc", "mmd", "novelty", "shiv")
SOURCE_TRACKS = {"fig63": 40, "fig65": 50, "table61": 40}
LAPS = 2  # per episode: crashes per lap = -return / LAPS


def _protocol(track: int, iterations: int, eval_episodes: int) -> dict:
    """What DAgger and SHIV share: the track, the learner, one demonstration an iteration,
    every state of it kept, and the evaluation."""
    return dict(
        env_id=ENV_ID,
        env_kwargs={"track_seed": track},
        policy=POLICY,
        iterations=iterations,
        demos_per_iteration=1,
        samples_per_demo=None,
        eval_episodes=eval_episodes,
        seed=track,
    )


@functools.cache
def track_scale(track: int) -> float:
    """The track's HOG distance scale: median distance between the distinct states of one
    supervisor demonstration (its own seed, apart from every run's)."""
    env = make_env(ENV_ID, {"track_seed": track})
    seed = int(np.random.default_rng([track, 0x5CA1E]).integers(SEED_BOUND))
    scale = median_state_distance(rollout(env, SUPERVISOR, seed).states)
    env.close()
    return scale


def shiv_config(
    track: int, sigma: float, iterations: int, eval_episodes: int, raw: bool = False
) -> shiv.SHIVConfig:
    """SHIV with the source's ``sigma`` (and sigma_r = 200) mapped to the track's scale
    (``raw``: both used as they stand, in HOG units, the ablation)."""

    def scaled(value: float) -> float:
        return value if raw else source_sigma(value, track_scale(track))

    return shiv.SHIVConfig(
        **_protocol(track, iterations, eval_episodes),
        selector="shiv",
        nu=NU,
        sigma=scaled(sigma),
        nu_r=NU_R,
        sigma_r=scaled(SIGMA_R),
        epsilon=None,  # Discrete actions: 0/1 loss with epsilon = 0 (Eq. 7)
        initial_demos=1,
    )


def run_curve(
    algo: str, track: int, sigma: float, iterations: int, eval_episodes: int, raw: bool = False
) -> dict:
    """One DAgger or SHIV run: crashes per lap and labels after every iteration."""
    t0 = time.process_time()
    if algo == "dagger":
        config = dagger.DAggerConfig(
            **_protocol(track, iterations, eval_episodes),
            beta=0.0,
            beta_schedule="constant",
            initial_demos=1,
        )
        result = dagger.run(config)
    else:
        result = shiv.run(shiv_config(track, sigma, iterations, eval_episodes, raw))
    records = result.evaluated()
    return {
        "algo": algo,
        "track": track,
        "sigma": sigma,
        "raw_sigma": raw,
        "hog_scale": track_scale(track) if algo == "shiv" else None,
        "supervisor_crashes_per_lap": -result.supervisor_return / LAPS,
        "labels": [r.labels_requested for r in records],
        "crashes_per_lap": [-r.eval_return / LAPS for r in records],
        "queried": [r.extras.get("queried") for r in records],
        "visited": [r.extras.get("visited") for r in records],
        "cpu_seconds": round(time.process_time() - t0, 1),
    }


def run_false_negatives(track: int) -> dict:
    """Fig. 6.5 on one track: false-negative share of each selector in the first rollout."""
    t0 = time.process_time()
    env = make_env(ENV_ID, {"track_seed": track})
    rng = np.random.default_rng([track, 0x65])
    seeds = [int(s) for s in rng.integers(SEED_BOUND, size=3)]
    demos = [rollout(env, SUPERVISOR, s) for s in seeds[:2]]  # D0: two demonstrations
    X0 = np.concatenate([d.states for d in demos])
    y0 = np.concatenate([d.labels for d in demos])
    policy = fit_policy(POLICY, env.action_space, X0, y0, int(rng.integers(SEED_BOUND)))
    sigma = source_sigma(SIGMA, track_scale(track))
    sigma_r = source_sigma(SIGMA_R, track_scale(track))
    selectors = {
        "confidence": ConfidenceSelector(env.action_space, rng, svm=POLICY),
        "qbc": CommitteeSelector(env.action_space, rng, members=3, fraction=0.8, svm=POLICY),
        "mmd": MMDSelector(nu=NU, sigma=sigma),
        "novelty": NoveltySelector(nu=NU, sigma=sigma),
        "shiv": ShivSelector(True, nu=NU, sigma=sigma, nu_r=NU_R, sigma_r=sigma_r, epsilon=None),
    }
    trajectory = rollout(env, LearnerActor(policy), seeds[2])  # the first policy rollout
    states, labels = trajectory.states, trajectory.labels
    truly_risky = policy.predict(states) != labels
    out: dict[str, Any] = {
        "track": track,
        "hog_scale": track_scale(track),
        "states": len(states),
        "truly_risky": int(truly_risky.sum()),
        "false_negative_share": {},
        "marked_risky_share": {},
    }
    for name, selector in selectors.items():
        selector.fit(X0, y0, policy)
        risky = selector.risky(states)
        out["marked_risky_share"][name] = float(risky.mean())
        out["false_negative_share"][name] = (
            float(np.mean(~risky[truly_risky])) if truly_risky.any() else None
        )
    env.close()
    out["cpu_seconds"] = round(time.process_time() - t0, 1)
    return out


def units(
    experiments: list[str],
    tracks: dict[str, int],
    iterations: int,
    episodes: int,
    sigmas: tuple[float, ...] = TABLE_SIGMAS,
    raw: bool = False,
):
    """(key, function, args) of every unit of work, each computed once."""
    todo: dict[str, tuple] = {}
    # cheapest first, and Table 6.1 track by track: a run stopped early leaves whole experiments
    # and, for Table 6.1, every sigma on the same first tracks
    if "fig65" in experiments:
        for t in range(tracks["fig65"]):
            todo[f"fn_t{t}"] = (run_false_negatives, (t,))
    if "fig63" in experiments:
        for t in range(tracks["fig63"]):
            todo[f"dagger_t{t}"] = (run_curve, ("dagger", t, 0.0, iterations, episodes))
            todo[f"shiv_s200_t{t}"] = (run_curve, ("shiv", t, SIGMA, iterations, episodes))
    if "table61" in experiments:
        for t in range(tracks["table61"]):
            for s in sigmas:
                todo[f"{table61_prefix(raw)}{s:g}_t{t}"] = (
                    run_curve, ("shiv", t, s, iterations, episodes, raw),
                )  # fmt: skip
    return todo


def _mean_se(values: list[float]) -> tuple[float, float]:
    a = np.asarray(values, dtype=float)
    se = float(a.std(ddof=1) / np.sqrt(len(a))) if len(a) > 1 else 0.0
    return float(a.mean()), se


def _normalised(run: dict) -> list[float | None]:
    sup = run["supervisor_crashes_per_lap"]
    return [c / sup if sup > 0 else None for c in run["crashes_per_lap"]]


def _first_crossing(labels: np.ndarray, values: np.ndarray, level: float) -> float | None:
    """Labels at which a mean curve first reaches ``level`` (linear interpolation)."""
    for i, v in enumerate(values):
        if v <= level:
            if i == 0:
                return float(labels[0])
            x0, x1, v0 = labels[i - 1], labels[i], values[i - 1]
            return float(x0 + (x1 - x0) * (v0 - level) / (v0 - v))
    return None


def summarise_fig63(done: dict[str, dict], n: int) -> dict | None:
    curves = {}
    for algo, prefix in (("dagger", "dagger_t"), ("shiv", "shiv_s200_t")):
        runs = [done[f"{prefix}{t}"] for t in range(n) if f"{prefix}{t}" in done]
        runs = [r for r in runs if r["supervisor_crashes_per_lap"] > 0]
        if not runs:
            return None
        norm = np.array([_normalised(r) for r in runs], dtype=float)
        labels = np.array([r["labels"] for r in runs], dtype=float)
        crashes = np.array([r["crashes_per_lap"] for r in runs], dtype=float)
        se = norm.std(axis=0, ddof=1) / np.sqrt(len(runs)) if len(runs) > 1 else 0 * norm[0]
        curves[algo] = {
            "tracks": len(runs),
            "labels": labels.mean(axis=0).round(1).tolist(),
            "normalised": norm.mean(axis=0).round(3).tolist(),
            "normalised_se": np.round(se, 3).tolist(),
            "crashes_per_lap": crashes.mean(axis=0).round(3).tolist(),
            "supervisor_crashes_per_lap": round(
                float(np.mean([r["supervisor_crashes_per_lap"] for r in runs])), 3
            ),
        }
    # the query reduction at the supervisor's level (1.0), or else at the best level both reach
    level = max(1.0, max(min(c["normalised"]) for c in curves.values()))
    crossing = {
        a: _first_crossing(np.array(c["labels"]), np.array(c["normalised"]), level)
        for a, c in curves.items()
    }
    reduction = None
    if crossing["dagger"] and crossing["shiv"] is not None:
        reduction = round(1.0 - crossing["shiv"] / crossing["dagger"], 3)
    final = {a: (c["labels"][-1], c["normalised"][-1]) for a, c in curves.items()}
    return {
        "curves": curves,
        # after the last iteration: SHIV's labels as a share of DAgger's, and both performances
        "final_label_share": round(final["shiv"][0] / final["dagger"][0], 3),
        "final_normalised": {a: f[1] for a, f in final.items()},
        "level": round(level, 3),
        "labels_to_reach": crossing,
        "reduction": reduction,
    }


def summarise_fig65(done: dict[str, dict], n: int) -> dict | None:
    runs = [done[f"fn_t{t}"] for t in range(n) if f"fn_t{t}" in done]
    if not runs:
        return None
    out = {"tracks": len(runs), "mean_truly_risky": _mean_se([r["truly_risky"] for r in runs])}
    for name in SELECTOR_NAMES:
        fn = [r["false_negative_share"][name] for r in runs]
        fn = [v for v in fn if v is not None]
        asked = [r["marked_risky_share"][name] for r in runs]
        out[name] = {
            "false_negative_share": _mean_se(fn) if fn else None,
            "marked_risky_share": _mean_se(asked),
        }
    return out


def table61_prefix(raw: bool) -> str:
    """Unit key prefix: the raw-sigma ablation never shares units with the mapped runs."""
    return "shiv_raw_s" if raw else "shiv_s"


def summarise_table61(
    done: dict[str, dict], n: int, sigmas: tuple[float, ...] = TABLE_SIGMAS, raw: bool = False
) -> dict | None:
    rows = {}
    wanted = sorted(set(sigmas))
    # only tracks where every sigma has run: the rows then compare the same tracks
    complete = [
        t for t in range(n) if all(f"{table61_prefix(raw)}{s:g}_t{t}" in done for s in wanted)
    ]
    for s in wanted:
        runs = [done[f"{table61_prefix(raw)}{s:g}_t{t}"] for t in complete]
        if runs:
            rows[f"{s:g}"] = {
                "tracks": len(runs),
                "crashes_per_lap": _mean_se([r["crashes_per_lap"][-1] for r in runs]),
                "states_labelled": _mean_se([r["labels"][-1] for r in runs]),
                "supervisor_crashes_per_lap": _mean_se(
                    [r["supervisor_crashes_per_lap"] for r in runs]
                ),
            }
    return rows or None


def plot_fig63(summary: dict, path: Path) -> None:
    figure = new_figure(1, 1, (6.0, 4.2))
    axes = figure.axes[0]
    for algo, colour in (("dagger", "teal"), ("shiv", "tab:orange")):
        c = summary["curves"][algo]
        x, y, e = np.array(c["labels"]), np.array(c["normalised"]), np.array(c["normalised_se"])
        axes.errorbar(x, y, yerr=e, color=colour, ecolor="grey", marker="o", ms=3,
                      label=f"{algo.upper() if algo == 'shiv' else 'DAgger'}")  # fmt: skip
    axes.axhline(1.0, color="black", ls="--", lw=1, label="supervisor (depth-1 search)")
    tracks = summary["curves"]["dagger"]["tracks"]
    axes.set_title(f"DrivingTrack: SHIV vs DAgger, {tracks} tracks")
    axes.set_xlabel("states labelled by the supervisor")
    axes.set_ylabel("crashes per lap / supervisor's")
    save_png_atomic(figure, path)


def plot_fig65(summary: dict, path: Path) -> None:
    figure = new_figure(1, 1, (6.0, 4.0))
    axes = figure.axes[0]
    names = [n for n in SELECTOR_NAMES if summary[n]["false_negative_share"]]
    means = [100 * summary[n]["false_negative_share"][0] for n in names]
    errors = [100 * summary[n]["false_negative_share"][1] for n in names]
    labels = {"confidence": "confidence", "qbc": "QBC", "mmd": "MMD",
              "novelty": "One-Class SVM", "shiv": "SHIV"}  # fmt: skip
    axes.bar([labels[n] for n in names], means, yerr=errors, color="tab:blue", ecolor="black")
    axes.set_ylabel("truly risky states estimated safe (%)")
    axes.set_title(f"False negatives in the first policy rollout, {summary['tracks']} tracks")
    save_png_atomic(figure, path, legend_loc=None)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--experiments", nargs="+", default=["fig65", "fig63", "table61"],
        choices=["fig63", "fig65", "table61"],
    )  # fmt: skip
    parser.add_argument("--tracks", type=int, default=None, help="cap on tracks per experiment")
    parser.add_argument(
        "--sigmas", type=float, nargs="+", default=list(TABLE_SIGMAS),
        help="Table 6.1's sigmas to run (the source's six by default; others as an ablation)",
    )  # fmt: skip
    parser.add_argument(
        "--raw-sigma", action="store_true",
        help="ablation: Table 6.1's sigmas (and sigma_r = 200) in raw HOG units, unmapped; "
        "use its own --out",
    )  # fmt: skip
    parser.add_argument(
        "--summarise-only", action="store_true",
        help="run nothing: summarise and plot the finished units",
    )  # fmt: skip
    parser.add_argument("--iterations", type=int, default=6)
    parser.add_argument("--eval-episodes", type=int, default=2)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("out/reproduce_track_shiv"))
    parser.add_argument("--images", type=Path, default=Path("docs/images"))
    parser.add_argument(
        "--results", type=Path, default=None,
        help="the results file the docs read (default: docs/results/reproduce_track_shiv.json; "
        "with --raw-sigma, reproduce_track_shiv_raw_sigma.json)",
    )  # fmt: skip
    args = parser.parse_args()
    if args.results is None:
        name = "reproduce_track_shiv_raw_sigma" if args.raw_sigma else "reproduce_track_shiv"
        args.results = REPO / "docs" / "results" / f"{name}.json"
    if min(args.iterations, args.eval_episodes, args.workers, args.tracks or 1) < 1:
        parser.error("--iterations, --eval-episodes, --workers, --tracks: >= 1")
    tracks = {k: min(v, args.tracks or v) for k, v in SOURCE_TRACKS.items()}
    if min(args.sigmas) <= 0:
        parser.error("--sigmas: positive bandwidths")
    if args.raw_sigma and args.experiments != ["table61"]:
        parser.error("--raw-sigma: with --experiments table61 only")
    todo = units(
        args.experiments, tracks, args.iterations, args.eval_episodes, tuple(args.sigmas),
        args.raw_sigma,
    )  # fmt: skip
    unit_dir = args.out / "units"
    done = {}
    for key in todo:
        path = unit_dir / f"{key}.json"
        if path.exists():
            done[key] = json.loads(path.read_text())
    pending = [] if args.summarise_only else [k for k in todo if k not in done]
    expected = CPU_SECONDS_PER_UNIT * len(pending) / args.workers
    print(f"expected run time: ~{max(1, round(expected / 60))} min on {args.workers} free core(s)")
    machine_at_start = machine()
    start = time.perf_counter()
    with ProcessPoolExecutor(args.workers, initializer=one_blas_thread) as pool:
        futures = {pool.submit(todo[k][0], *todo[k][1]): k for k in pending}
        for future in tqdm(as_completed(futures), total=len(futures), desc="units"):
            key = futures[future]
            done[key] = future.result()
            write_json_atomic(unit_dir / f"{key}.json", done[key])
    summary = {
        "settings": {
            "env_id": ENV_ID,
            "policy": {"name": POLICY.name, "params": dict(POLICY.params)},
            "shiv": {
                "nu": NU,
                "sigma": SIGMA,
                "nu_r": NU_R,
                "sigma_r": SIGMA_R,
                "sigma_units": "HOG (raw ablation)"
                if args.raw_sigma
                else "source; x median HOG distance / 200 on each track",
            },
            "iterations": args.iterations,
            "eval_episodes": args.eval_episodes,
            "tracks": tracks,
            "wall_seconds_this_run": round(time.perf_counter() - start, 1),
            "cpu_seconds_all_units": round(sum(u["cpu_seconds"] for u in done.values()), 1),
        },
        "fig63": summarise_fig63(done, tracks["fig63"]) if "fig63" in args.experiments else None,
        "fig65": summarise_fig65(done, tracks["fig65"]) if "fig65" in args.experiments else None,
        "table61": summarise_table61(done, tracks["table61"], tuple(args.sigmas), args.raw_sigma)
        if "table61" in args.experiments
        else None,
    }
    write_json_atomic(args.out / "track_shiv.json", summary)
    results_file = {"command": command_line(), "seeds": "track_seed = track index; see the units"}
    results_file |= summary | {"machine": machine_at_start}
    args.results.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.results, results_file)
    print(f"wrote {args.results}")
    if summary["fig63"]:
        plot_fig63(summary["fig63"], args.images / "track_shiv_fig63.png")
    if summary["fig65"]:
        plot_fig65(summary["fig65"], args.images / "track_shiv_fig65.png")
    print(json.dumps({k: v for k, v in summary.items() if k != "fig63"}, indent=1))
    if summary["fig63"]:
        print(json.dumps({k: v for k, v in summary["fig63"].items() if k != "curves"}, indent=1))
        for algo, c in summary["fig63"]["curves"].items():
            print(algo, c["labels"], c["normalised"])


if __name__ == "__main__":
    main()
