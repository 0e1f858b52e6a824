"""Reproduce the source's Fig. 3.3 (trajectory level) and Fig. 3.4 (linear learner) on the
MuJoCo locomotion IL envs: BC, DAgger, DAgger-B, isotropic noise and DART.

The source's schedule (ch. 3), every parameter set here explicitly:

- 20 iterations, one demonstration each (the first a supervisor demonstration), 50
  state–label pairs subsampled per demonstration (Ho & Ermon's protocol);
- DAgger: beta = 0.5 with the source's exponentially decaying mixture (``beta_k = 0.5^k``),
  refit every iteration; DAgger-B: the same, refit only at iterations 2 and 8;
- isotropic noise: Sigma = I (``noise_std = 1``) on every demonstration;
- DART: noise covariance estimated at iterations 2 and 8 from the held-out pairs (the pairs the
  subsampling leaves over), alpha = T tr(Sigma_hat) (the estimate's own magnitude);
- learners evaluated at iterations 5, 10, 15, 20 by rolling them out for ``--eval-steps`` (500
  in the source);
- learner: ``mlp`` (two hidden layers of 64, Fig. 3.3) and ``linear`` (no hidden layer, i.e.
  least-squares linear regression, Fig. 3.4).

The source's Humanoid schedule (200 iterations; DAgger-B and DART start from 60 supervisor
demonstrations, then update every 15 iterations; evaluated at 50, 100, 150, 200) is
``--env Humanoid-IL-v0 --iterations 200 --eval-at 50 100 150 200 --initial-demos 60
--update-every 15``.

One JSON per (env, learner, method, seed) run in ``--out/runs/``, written atomically when the
run finishes, so a killed sweep resumes by skipping finished runs (refused, naming the file, if
one was made with another supervisor, schedule or env kwargs); ``--workers`` runs them in
parallel processes; a progress bar counts runs. Then ``summary.json`` (mean eval return per
iteration, collection return, training seconds) and ``<env>.png`` are written.

Reductions (state them when reporting): ``--iterations``, ``--eval-at``, ``--eval-episodes``,
``--seeds``, ``--env-kwargs`` (e.g. a cheaper planner).

The results file the docs read (``--results``; by default, for one env,
``docs/results/dart_mujoco_<task>.json``, ``..._fixed_trace.json`` when only ``dart_fixed`` runs)
holds the summary with the command line. A 20-iteration run (one learner, method and seed) costs
about 1-2 CPU-min on Hopper, Walker2d and HalfCheetah.

Example: ``nice -n 10 python scripts/reproductions/reproduce_dart_mujoco.py --env Hopper-IL-v0 --seeds 3
--workers 2 --out runs/dart_mujoco``
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fluids_bench.core.parallel import as_finished
from fluids_bench.core.provenance import command_line, machine

METHODS = ("bc", "dagger", "dagger_b", "isotropic", "dart")
# dart_fixed, an ablation not in the source: DART's covariance rescaled to a fixed trace
# (--dart-fixed-trace); dart_literal: the source's alpha = T tr(Sigma_k) read literally, the
# current estimate's trace times the demonstration length T (``dart`` injects Sigma_k itself)
EXTRA_METHODS = ("dart_fixed", "dart_literal")
LEARNERS = {
    "mlp": {"hidden_layer_sizes": [64, 64], "max_iter": 500},
    "linear": {"hidden_layer_sizes": [], "activation": "identity", "max_iter": 500},
}

REPO = Path(__file__).resolve().parents[2]
# measured CPU seconds per iteration of one run (learner, method, seed), averaged over the methods:
# a 20-iteration Hopper run takes about 90 s; the 30 runs of Humanoid's 200-iteration schedule
# took 67 min (each iteration's demonstration and fit are small beside its long schedule)
CPU_SECONDS_PER_ITERATION = {"Humanoid-IL-v0": 0.67}
DEFAULT_CPU_SECONDS_PER_ITERATION = 4.5


def run_one(env_id: str, env_kwargs: dict, learner: str, method: str, seed: int, s: dict) -> dict:
    import fluids_bench  # noqa: F401  (registers the ids in the worker)
    from fluids_bench.algos import bc, dagger, dart, noise
    from fluids_bench.algos.policies import PolicySpec

    common = dict(
        env_id=env_id,
        env_kwargs=env_kwargs,
        policy=PolicySpec(
            "mlp",
            {
                **LEARNERS[learner],
                "hidden_layer_sizes": tuple(LEARNERS[learner]["hidden_layer_sizes"]),
            },
        ),
        iterations=s["iterations"],
        demos_per_iteration=1,
        samples_per_demo=50,
        eval_episodes=s["eval_episodes"],
        eval_at=tuple(s["eval_at"]),
        max_steps=s["eval_steps"],
        return_floor=0.0,
        seed=seed,
    )
    t0 = time.perf_counter()
    if method == "bc":
        result = bc.run(bc.BCConfig(**common))
    elif method in ("dagger", "dagger_b"):
        batched = method == "dagger_b"
        result = dagger.run(
            dagger.DAggerConfig(
                **common,
                beta=0.5,
                beta_schedule="exponential",
                initial_demos=(s["initial_demos"] or 1) if batched else 1,
                retrain_at=tuple(s["update_at"]) if batched else None,
                retrain_every=s["update_every"] if batched else None,
            )
        )
    elif method == "isotropic":
        result = noise.run(noise.NoiseConfig(**common, noise_std=1.0, epsilon=0.0))
    else:
        result = dart.run(
            dart.DARTConfig(
                **common,
                alpha=s["dart_fixed_trace"] if method == "dart_fixed" else None,
                # T: the demonstrations' length (the rollout limit, --eval-steps)
                alpha_relative=float(s["eval_steps"]) if method == "dart_literal" else None,
                alpha_reference="current",
                update_at=tuple(s["update_at"]),
                update_every=s["update_every"],
                initial_demos=s["initial_demos"] or 0,
                heldout_fraction=0.0,
                initial_noise_std=0.0,
                initial_epsilon=0.0,
            )
        )
    return {
        "env_id": env_id,
        "learner": learner,
        "method": method,
        "seed": seed,
        "wall_seconds": time.perf_counter() - t0,
        "supervisor_return": result.supervisor_return,
        "supervisor": _supervisor_record(env_id, env_kwargs),
        "records": [
            {
                "iteration": r.iteration,
                "labels": r.labels_requested,
                "train_seconds": r.train_seconds,
                "collection_return": r.collection_return,
                "eval_return": r.eval_return,
                "extras": r.extras,
            }
            for r in result.records
        ],
    }


def _supervisor_record(env_id: str, env_kwargs: dict) -> dict:
    """Which supervisor labelled (kind and weights sha256), from the env's own record."""
    import gymnasium as gym

    env = gym.make(env_id, **env_kwargs)
    record = env.unwrapped.metadata["supervisor"]
    env.close()
    return {k: record[k] for k in ("kind", "weights_sha256") if k in record}


def _stale(run: dict, settings: dict, env_kwargs: dict, supervisor: dict) -> str | None:
    """What differs between a finished run and this command (None: it can be reused). A run
    made with other weights, e.g. before a new teacher was shipped, must not be mixed in."""
    if run.get("supervisor") != supervisor:
        return f"supervisor ({run.get('supervisor')} here: {supervisor})"
    if run.get("settings") != settings:
        return f"schedule ({run.get('settings')} here: {settings})"
    if run.get("env_kwargs", {}) != env_kwargs:
        return f"--env-kwargs ({run.get('env_kwargs')} here: {env_kwargs})"
    return None


def summarise(runs: list[dict]) -> dict[str, Any]:
    """Means over seeds. A record's ``train_seconds`` is cumulative (every fit so far), so a
    run's total is its last record's."""
    out: dict[str, Any] = {}
    for r in runs:
        key = f"{r['env_id']}/{r['learner']}/{r['method']}"
        out.setdefault(key, []).append(r)
    summary = {}
    for key, rs in sorted(out.items()):
        evals = [
            [
                (x["iteration"], x["eval_return"])
                for x in r["records"]
                if x["eval_return"] is not None
            ]
            for r in rs
        ]
        its = [i for i, _ in evals[0]]
        ev = np.array([[v for _, v in e] for e in evals])
        coll = np.array([[x["collection_return"] for x in r["records"]] for r in rs])
        summary[key] = {
            "seeds": len(rs),
            "eval_iterations": its,
            "eval_return_mean": ev.mean(0).round(1).tolist(),
            "eval_return_se": (ev.std(0) / np.sqrt(len(rs))).round(1).tolist(),
            "collection_return_mean": coll.mean(0).round(1).tolist(),
            "collection_iterations": [x["iteration"] for x in rs[0]["records"]],
            "train_seconds_total_mean": round(
                float(np.mean([r["records"][-1]["train_seconds"] for r in rs])), 2
            ),
            "wall_seconds_mean": round(float(np.mean([r["wall_seconds"] for r in rs])), 1),
            "supervisor_return_mean": round(
                float(np.mean([r["supervisor_return"] for r in rs])), 1
            ),
            "noise_trace_mean": [
                None if v is None else round(float(v), 4)
                for v in _mean_or_none(
                    [[x["extras"].get("noise_level") for x in r["records"]] for r in rs]
                )
            ],
            "supervisor": rs[0].get("supervisor"),
        }
    return summary


def _mean_or_none(rows: list[list]) -> list:
    """Column means of equal-length rows, None where any row has None."""
    return [None if None in col else float(np.mean(col)) for col in zip(*rows, strict=True)]


def plot(summary: dict, env_id: str, path: Path) -> None:
    from fluids_bench.algos.plots import new_figure, save_png_atomic

    fig = new_figure(1, 3, (15, 4))
    axes = fig.axes
    for key, s in summary.items():
        env, learner, method = key.split("/")
        if env != env_id:
            continue
        style = "-" if learner == "mlp" else "--"
        its = s["eval_iterations"]
        axes[0 if learner == "mlp" else 1].errorbar(
            its,
            s["eval_return_mean"],
            s["eval_return_se"],
            ls=style,
            marker="o",
            label=method,
            capsize=3,
        )
        if learner == "mlp":
            axes[2].plot(
                range(1, len(s["collection_return_mean"]) + 1),
                s["collection_return_mean"],
                label=method,
            )
    sup = next(s["supervisor_return_mean"] for k, s in summary.items() if k.startswith(env_id))
    for ax, title in zip(
        axes,
        (
            "MLP 64x64 learner (Fig. 3.3)",
            "linear learner (Fig. 3.4)",
            "reward during collection (MLP runs)",
        ),
        strict=True,
    ):
        ax.axhline(sup, color="k", lw=0.8, ls=":", label="supervisor")
        ax.set_title(f"{env_id}: {title}", fontsize=9)
        ax.set_xlabel("iteration (demonstrations)")
        ax.set_ylabel("return")
    save_png_atomic(fig, path)


def main(argv: list[str] | None = None) -> int:
    from fluids_bench.algos.results import write_json_atomic

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", nargs="+", default=["HalfCheetah-IL-v0"])
    p.add_argument("--env-kwargs", type=json.loads, default={}, help="JSON kwargs for gym.make")
    p.add_argument("--learners", nargs="+", default=list(LEARNERS), choices=list(LEARNERS))
    p.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS + EXTRA_METHODS)
    p.add_argument("--dart-fixed-trace", type=float, default=0.5, help="tr(Sigma) of dart_fixed")
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--iterations", type=int, default=20)
    p.add_argument("--eval-at", type=int, nargs="+", default=[5, 10, 15, 20])
    p.add_argument("--update-at", type=int, nargs="+", default=[2, 8])
    p.add_argument(
        "--update-every",
        type=int,
        default=None,
        help="DAgger-B and DART update every N iterations (replaces --update-at)",
    )
    p.add_argument(
        "--initial-demos",
        type=int,
        default=None,
        help="supervisor demonstrations DAgger-B and DART start from, at iteration 0 (the "
        "source's Humanoid: 60; default: DAgger-B one, DART none, its first iterations being "
        "noise-free supervisor demonstrations)",
    )
    p.add_argument("--eval-episodes", type=int, default=5)
    p.add_argument("--eval-steps", type=int, default=500)
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--out", type=Path, default=Path("runs/dart_mujoco"))
    p.add_argument(
        "--results", type=Path, default=None,
        help="the results file the docs read (default with one env: "
        "docs/results/dart_mujoco_<task>[_fixed_trace].json; with several: none)",
    )  # fmt: skip
    p.add_argument(
        "--summarise-only",
        action="store_true",
        help="summarise and plot the finished runs, run none",
    )
    args = p.parse_args(argv)
    settings = {
        "iterations": args.iterations,
        "eval_at": args.eval_at,
        "update_at": args.update_at,
        "update_every": args.update_every,
        "initial_demos": args.initial_demos,
        "eval_episodes": args.eval_episodes,
        "eval_steps": args.eval_steps,
        "dart_fixed_trace": args.dart_fixed_trace,
    }
    (args.out / "runs").mkdir(parents=True, exist_ok=True)
    jobs, runs = [], []
    for env_id in args.env:
        supervisor = _supervisor_record(env_id, args.env_kwargs)
        for learner in args.learners:
            for method in args.methods:
                for seed in range(args.seeds):
                    path = args.out / "runs" / f"{env_id}_{learner}_{method}_{seed}.json"
                    if path.exists():
                        run = json.loads(path.read_text())
                        stale = _stale(run, settings, args.env_kwargs, supervisor)
                        if stale:
                            p.error(
                                f"{path} was made with another {stale}; resume with the "
                                "command that made it, or pass a new --out"
                            )
                        runs.append(run)
                    elif not args.summarise_only:
                        jobs.append(
                            (path, (env_id, args.env_kwargs, learner, method, seed, settings))
                        )
    if args.results is None and len(args.env) == 1:
        name = "dart_mujoco_" + args.env[0].split("-")[0].lower()
        name += "_fixed_trace" if args.methods == ["dart_fixed"] else ""
        name += "_alpha" if "dart_literal" in args.methods else ""
        args.results = REPO / "docs" / "results" / f"{name}.json"
    per_iteration = [
        CPU_SECONDS_PER_ITERATION.get(job[1][0], DEFAULT_CPU_SECONDS_PER_ITERATION) for job in jobs
    ]
    expected = sum(per_iteration) * args.iterations / args.workers
    print(f"expected run time: ~{max(1, round(expected / 60))} min on {args.workers} free core(s)")
    machine_at_start = machine()
    try:
        done = as_finished(run_one, [job for _, job in jobs], args.workers)
        for i, result in tqdm(done, total=len(jobs), desc="runs"):
            path = jobs[i][0]
            result["settings"] = settings
            result["env_kwargs"] = args.env_kwargs
            write_json_atomic(path, result)
            runs.append(result)
    except KeyboardInterrupt:
        print("interrupted: finished runs are saved; run the same command to resume")
        return 130
    if not runs:
        print("no finished runs")
        return 1
    summary = summarise(runs)
    write_json_atomic(
        args.out / "summary.json",
        {"settings": settings, "env_kwargs": args.env_kwargs, "summary": summary},
    )
    if args.results is not None:
        args.results.parent.mkdir(parents=True, exist_ok=True)
        write_json_atomic(
            args.results,
            {
                "command": command_line(),
                "seeds": f"0-{args.seeds - 1}",
                "settings": settings,
                "env_kwargs": args.env_kwargs,
                "machine": machine_at_start,
                "summary": summary,
            },
        )
        print(f"wrote {args.results}")
    for env_id in args.env:
        plot(summary, env_id, args.out / f"{env_id}.png")
    print(markdown(summary))
    return 0


def markdown(summary: dict[str, Any]) -> str:
    """The README's table: mean eval return per evaluation iteration, collection, compute."""
    lines = []
    for key, s in summary.items():
        if not lines:
            its = " | ".join(f"iter {i}" for i in s["eval_iterations"])
            lines = [
                f"| env / learner / method | seeds | {its} | mean collection return | fit seconds |",
                "|---" * (4 + len(s["eval_iterations"])) + "|",
            ]
        evals = " | ".join(
            f"{m:,.0f} ± {e:,.0f}"
            for m, e in zip(s["eval_return_mean"], s["eval_return_se"], strict=True)
        )
        coll = np.mean(s["collection_return_mean"])
        lines.append(
            f"| {key} | {s['seeds']} | {evals} | {coll:,.0f} | {s['train_seconds_total_mean']:,.0f} |"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
