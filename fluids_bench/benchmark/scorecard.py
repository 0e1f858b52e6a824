"""A scorecard: one policy's scores on a suite, with everything needed to trust and redo them.

Built from the episode rows of the policy and of the two references (random, supervisor) on
the same episodes. Holds the suite (ids, kwargs, seeds, whether it was shortened), per task and
set the mean return, the normalised score, success and (where the env reports it) the driving
score with 95 % intervals, the suite's mean and IQM with stratified-bootstrap intervals, the
policy's label-efficiency curve when it is a train run, and provenance: git revision, package
versions, command, machine.
"""

from __future__ import annotations

import importlib.metadata
import os
import platform
import subprocess
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from fluids_bench.benchmark import metrics
from fluids_bench.benchmark.suite import Suite

SCORECARD_VERSION = 1
PACKAGES = (
    "fluids-bench", "gymnasium", "numpy", "numba", "shapely", "pymunk", "mujoco",
    "scikit-learn", "rliable", "torch", "stable-baselines3",
)  # fmt: skip
Rows = Mapping[str, list[dict[str, Any]]]  # policy name -> its rows of one (task, set)


def git_revision() -> str | None:
    """The checkout's commit, with `-dirty` when the code that computes results (the package,
    pyproject.toml) has uncommitted changes (results files being written do not count), or
    None outside git."""
    here = Path(__file__).resolve().parent
    try:
        rev = subprocess.run(
            ["git", "-C", str(here), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            [
                "git",
                "-C",
                str(here.parent.parent),
                "status",
                "--porcelain",
                "--untracked-files=no",
                "--",
                "fluids_bench",
                "pyproject.toml",
            ],  # fmt: skip
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None
    return rev + ("-dirty" if dirty else "")


def package_versions() -> dict[str, str | None]:
    out: dict[str, str | None] = {}
    for name in PACKAGES:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = None
    return out


def provenance(command: str | None) -> dict[str, Any]:
    import os

    return {
        "git_revision": git_revision(),
        "packages": package_versions(),
        "python": platform.python_version(),
        "command": command,
        "machine": f"{os.cpu_count()} cores ({platform.machine()})",
    }


def _mean_or_none(values: list[Any]) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def _triple(values: list[float]) -> list[float]:
    return list(metrics.interval(values))


def set_scores(rows: Rows, policy: str) -> dict[str, Any]:
    """Scores of `policy` on one set from the rows of it and the references (same seeds)."""
    mine = rows[policy]
    returns = [r["return"] for r in mine]
    random_returns = [r["return"] for r in rows["random"]]
    supervisor_returns = [r["return"] for r in rows["supervisor"]]
    out: dict[str, Any] = {
        "episodes": len(mine),
        "return": _triple(returns),
        "random_return": float(np.mean(random_returns)),
        "supervisor_return": float(np.mean(supervisor_returns)),
        "normalised": None,
        "normalised_episodes": None,
    }
    try:
        scores = metrics.normalised_scores(returns, random_returns, supervisor_returns)
    except ValueError as exc:
        out["note"] = str(exc)
    else:
        # the point is (mean R - mean R_random) / (mean R_sup - mean R_random), exactly 0 and 1
        # for the references; the interval is the bootstrap's over the per-episode scores
        low, high = out["random_return"], out["supervisor_return"]
        point = (float(np.mean(returns)) - low) / (high - low)
        out["normalised"] = [point, *_triple(scores.tolist())[1:]]
        out["normalised_episodes"] = [round(float(s), 12) for s in scores]
    # Gymnasium's convention: info["is_success"] on the last step. Where the env reports it on
    # some episode, an episode that ended without it (truncated by the time limit) failed.
    reports = any(r["success"] is not None for rs in rows.values() for r in rs)
    if reports:

        def rate(rs: list[dict[str, Any]]) -> list[float]:
            return [float(bool(r["success"])) for r in rs]

        out["success"] = _triple(rate(mine))
        out["random_success"] = float(np.mean(rate(rows["random"])))
        out["supervisor_success"] = float(np.mean(rate(rows["supervisor"])))
    scored = [r for r in mine if "driving_score" in r]
    if scored:  # FLUIDS-v4 reports it at an episode's end; the count says if some lacked it
        out["driving_score"] = _triple([float(r["driving_score"]) for r in scored])
        out["driving_score_episodes"] = len(scored)
        out["random_driving_score"] = _mean_or_none(
            [r.get("driving_score") for r in rows["random"]]
        )
        out["supervisor_driving_score"] = _mean_or_none(
            [r.get("driving_score") for r in rows["supervisor"]]
        )
        out["route_completion"] = _mean_or_none([r.get("route_completion") for r in mine])
        infractions: dict[str, list[float]] = {}
        for r in mine:
            for k, v in (r.get("infractions") or {}).items():
                infractions.setdefault(k, []).append(float(v))
        out["infractions"] = {k: float(np.sum(v)) / len(mine) for k, v in infractions.items()}
    return out


PATH_KEYS = ("spec", "train_result", "learner_checkpoint")  # file paths in a policy entry


def _relative_paths(entry: Any) -> Any:
    """`entry` with every absolute file path under `PATH_KEYS` shown relative to the working
    directory (a results file records no machine's folders)."""
    if isinstance(entry, Mapping):
        return {
            key: os.path.relpath(value)
            if key in PATH_KEYS and isinstance(value, str) and os.path.isabs(value)
            else _relative_paths(value)
            for key, value in entry.items()
        }
    return entry


def build(
    name: str,
    policy: dict[str, Any],
    suite: Suite,
    rows_of: Callable[[str, str, str], Rows],
    command: str | None = None,
    observation: Mapping[str, Mapping[str, Any]] | None = None,
) -> dict[str, Any]:
    """The scorecard of policy `name` on `suite`.

    Args:
        name: the policy's name.
        policy: what the scorecard says about the policy (its spec, kind, train run, ...).
        suite: the evaluated suite.
        rows_of: `(policy, task, set) -> rows` for the policy and the references.
        command: the command line that produced it.
        observation: per task, the observation kwargs the policy's episodes ran with on top of
            each set's kwargs (a policy trained with another observation); recorded in the
            task's entry and each set's `policy_kwargs`.
    """
    tasks: dict[str, Any] = {}
    per_split: dict[str, dict[str, list[float]]] = {"test": {}, "ood": {}}
    for task in suite.tasks:
        sets: dict[str, Any] = {}
        for set_name, kwargs, seeds in task.eval_sets(suite.episodes):
            rows = {p: rows_of(p, task.name, set_name) for p in {name, "random", "supervisor"}}
            scores = set_scores(rows, name)
            scores["kwargs"] = kwargs
            own = dict((observation or {}).get(task.name) or {})
            if own:
                scores["policy_kwargs"] = {**kwargs, **own}
            scores["seeds"] = {
                "split": "test" if set_name == "test" else "ood",
                "first": seeds[0],
                "count": len(seeds),
            }
            sets[set_name] = scores
            episodes = scores.pop("normalised_episodes")
            if episodes is not None:
                split = "test" if set_name == "test" else "ood"
                per_split[split].setdefault(task.name, []).extend(episodes)
        tasks[task.name] = {
            "env_id": task.env_id,
            "env_kwargs": dict(task.env_kwargs),
            "sets": sets,
        }
        if (observation or {}).get(task.name):
            tasks[task.name]["observation_kwargs"] = dict(observation[task.name])
    aggregate = {
        split: (metrics.aggregate(scores) if scores else None)
        for split, scores in per_split.items()
    }
    card: dict[str, Any] = {
        "scorecard_version": SCORECARD_VERSION,
        "policy": _relative_paths(policy),
        "suite": suite.to_dict(),
        "shortened": suite.shortened,
        "episodes_per_set": suite.episodes,
        "tasks": tasks,
        "aggregate": aggregate,
        "command": command,  # as every results file of the docs has it
        "provenance": provenance(command),
    }
    described = policy.get("tasks") or {t.name: policy for t in suite.tasks}
    curves = {
        task: metrics.label_efficiency(
            entry["learning_curve"]["labels"], entry["learning_curve"]["normalised_performance"]
        )
        for task, entry in described.items()
        if entry.get("learning_curve")
    }
    if curves:
        card["label_efficiency"] = curves
    return card
