"""`evaluate(policy, suite)`: a policy on the suite's test and OOD sets, resumable, to a scorecard.

The policy, the random policy and the supervisor each run every episode of every set (the
references normalise the score on the same episodes). A policy's FLUIDS episodes are stepped
`batch` at a time on the id's vector env where the policy can act on a batch, each row the
same as its episode run alone. Episodes run on `workers` processes
(the project's pool, [`process_pool`][fluids_bench.core.parallel.process_pool]) or here; each
finished episode is appended at once to `OUT/episodes/<policy>.jsonl`, so Ctrl-C keeps them
and a rerun of the same evaluation runs only the missing ones (the reference logs are shared by
every policy evaluated into the same `OUT`). The scorecard JSON is written atomically at the
end, its plot in `OUT`.
"""

from __future__ import annotations

import os
import pickle
import re
from collections.abc import Mapping
from concurrent.futures import as_completed
from pathlib import Path
from typing import Any

from fluids_bench.algos.vector_rollout import DEFAULT_BATCH
from fluids_bench.benchmark import scorecard as scorecards
from fluids_bench.benchmark.episodes import (
    EpisodeJob,
    EpisodeLog,
    init_worker,
    kwargs_json,
    run_episode,
    run_vector_chunk,
    run_vector_jobs,
    vector_group,
)
from fluids_bench.benchmark.policies import BUILT_INS, PolicySource, ensure_learner, resolve
from fluids_bench.benchmark.suite import SUITE, Suite, Task

REFERENCES = BUILT_INS  # random (score 0) and supervisor (score 1)
NAME_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]{0,99}$")


def _check_name(name: str) -> str:
    if not NAME_PATTERN.match(name):
        raise ValueError(
            f"policy name {name!r}; allowed: letters, digits and _ . + - (a file name), "
            "at most 100 characters"
        )
    return name


def _assign(
    policy: Any, suite: Suite, name: str | None
) -> tuple[str, Suite, dict[str, PolicySource]]:
    """The policy's name, the tasks it is evaluated on and its source per task.

    A single-env policy (a train result) is evaluated on the tasks of its env id; a model file
    or learner checkpoint, whose env is not recorded, needs a suite of one task or a mapping
    `{task: policy}`.
    """
    if isinstance(policy, Mapping):
        if not policy:
            raise ValueError("policy mapping is empty; allowed: {task name: policy}")
        chosen = suite.select(suite.episodes, list(policy))
        if name is None:
            raise ValueError("a policy per task needs a name (--name)")
        sources = {task: resolve(p, name) for task, p in policy.items()}
        for task in chosen.tasks:
            _check_env(name, sources[task.name], task)
        return _check_name(name), chosen, sources
    source = resolve(policy, name)
    name = _check_name(source.name)
    if name in REFERENCES and source.kind != name:
        raise ValueError(f"policy name {name!r} is a reference's; allowed: another --name")
    tasks = suite.tasks
    env_id = source.extras.get("env_id")
    if env_id is not None:  # a train run: the tasks of its env
        tasks = tuple(t for t in suite.tasks if t.env_id == env_id)
        if not tasks:
            raise ValueError(
                f"policy {name!r} was trained on {env_id}; the suite's tasks are "
                f"{[f'{t.name} ({t.env_id})' for t in suite.tasks]}"
            )
    elif source.kind in ("sb3", "learner") and len(tasks) != 1:
        raise ValueError(
            f"policy {name!r} ({source.kind}) does not record its env; allowed: one task "
            f"(--tasks NAME) or a policy per task; tasks: {[t.name for t in tasks]}"
        )
    for task in tasks:
        _check_env(name, source, task)
    chosen = suite.select(suite.episodes, [t.name for t in tasks])
    return name, chosen, {t.name: source for t in chosen.tasks}


def _check_env(name: str, source: PolicySource, task: Task) -> dict[str, Any]:
    """A train run's learner is evaluated only on its own env id and kwargs, up to the task's
    observation kwargs; returns the observation kwargs the run set otherwise than the task
    (its episodes run with them: the same episodes, seen through the run's observation)."""
    env_id = source.extras.get("env_id")
    if env_id is None:
        return {}
    kwargs = dict(source.extras.get("env_kwargs", {}))
    task_kwargs = dict(task.env_kwargs)
    differ = sorted(k for k in set(kwargs) | set(task_kwargs) if kwargs.get(k, _UNSET)
                    != task_kwargs.get(k, _UNSET))  # fmt: skip
    others = [k for k in differ if k not in task.observation_kwargs or k not in kwargs]
    if env_id != task.env_id or others:
        allowed = (
            f"; only the observation kwargs {list(task.observation_kwargs)} may differ"
            if task.observation_kwargs
            else ""
        )
        raise ValueError(
            f"policy {name!r} was trained on {env_id} with kwargs {kwargs}; task {task.name!r} "
            f"is {task.env_id} with {task_kwargs} (train with those{allowed})"
        )
    return {k: kwargs[k] for k in differ}


_UNSET = object()


def _describe(name: str, per_task: dict[str, PolicySource]) -> dict[str, Any]:
    """The scorecard's policy entry: the source's, or one per task when they differ."""
    sources = list(per_task.values())
    if all(s is sources[0] for s in sources):
        return {**sources[0].describe(), "name": name}
    return {
        "name": name,
        "kind": "per_task",
        "tasks": {task: source.describe() for task, source in per_task.items()},
    }


def _jobs(
    name: str, suite: Suite, observation: Mapping[str, Mapping[str, Any]] | None = None
) -> list[tuple[EpisodeJob, Task]]:
    """Every episode of the policy and the references; the policy's run with `observation`'s
    kwargs of its task on top of the set's (the references' do not: they ignore observations)."""
    out = []
    policies = [name] + [r for r in REFERENCES if r != name]
    for task in suite.tasks:
        own = dict((observation or {}).get(task.name, {}))
        for set_name, kwargs, seeds in task.eval_sets(suite.episodes):
            text = kwargs_json(kwargs)
            own_text = kwargs_json({**kwargs, **own})
            for seed in seeds:
                for policy in policies:
                    where = own_text if policy == name else text
                    out.append(
                        (EpisodeJob(policy, task.name, set_name, task.env_id, where, seed), task)
                    )
    return out


def _check_picklable(sources: dict[tuple[str, str], PolicySource]) -> None:
    for (policy, task), source in sources.items():
        try:
            pickle.dumps(source)
        except Exception as exc:  # noqa: BLE001  (any pickling failure)
            raise ValueError(
                f"policy {policy!r} on {task!r} cannot be sent to worker processes ({exc}); "
                "allowed: workers=1, or a picklable policy / a module:factory spec"
            ) from exc


def _groups(
    pending: list[tuple[EpisodeJob, Task]], batch: int
) -> tuple[list[tuple[list[EpisodeJob], Task]], list[tuple[EpisodeJob, Task]]]:
    """The jobs stepped together on a vector env (by `vector_group`) and those run alone
    (all of them with `batch=1`)."""
    if batch == 1:
        return [], list(pending)
    groups: dict[tuple[str, str, str, str], tuple[list[EpisodeJob], Task]] = {}
    alone = []
    for job, task in pending:
        key = vector_group(job, task)
        if key is None:
            alone.append((job, task))
        else:
            groups.setdefault(key, ([], task))[0].append(job)
    return list(groups.values()), alone


def run_jobs(
    jobs: list[tuple[EpisodeJob, Task]],
    sources: dict[tuple[str, str], PolicySource],
    logs: dict[str, EpisodeLog],
    workers: int,
    progress: bool,
    batch: int = DEFAULT_BATCH,
) -> None:
    """Run the jobs not yet in their logs, appending each row as it finishes.

    The episodes of one policy on one env (id and kwargs) are stepped `batch` at a time on
    the id's vector env where it has one and the policy can act on a batch (each row equal to
    its scalar episode's); the others run one by one. With `workers`, each worker runs chunks
    of up to `batch` such episodes (their rows are written when the chunk ends) or single
    episodes."""
    from tqdm import tqdm

    pending = [(job, task) for job, task in jobs if not logs[job.policy].done(job)]
    with tqdm(
        total=len(jobs), initial=len(jobs) - len(pending), desc="evaluate", unit="episode",
        disable=not progress,
    ) as bar:  # fmt: skip
        if not pending:
            return
        for key in {(job.policy, job.task) for job, _ in pending}:
            ensure_learner(sources[key])  # a train result's learner, rebuilt only if needed

        def keep(row: dict[str, Any]) -> None:
            logs[row["policy"]].append(row)
            bar.update(1)

        init_worker(sources)  # here too: which jobs share a vector env
        groups, alone = _groups(pending, batch)
        if workers == 1:
            for group, task in groups:
                run_vector_jobs(group, task, keep, batch)
            for job, task in alone:
                keep(run_episode(job, task))
            return
        from fluids_bench.core.parallel import process_pool

        _check_picklable(sources)
        preload = ("fluids_bench", "fluids_bench.benchmark.episodes")
        with process_pool(workers, "forkserver", preload, init_worker, (sources,)) as pool:
            futures = []
            for group, task in groups:  # chunks that keep every worker busy
                size = min(batch, -(-len(group) // workers))
                for start in range(0, len(group), size):
                    chunk = group[start : start + size]
                    futures.append(pool.submit(run_vector_chunk, chunk, task, batch))
            futures += [pool.submit(run_episode, job, task) for job, task in alone]
            for future in as_completed(futures):
                result = future.result()
                for row in result if isinstance(result, list) else [result]:
                    keep(row)


def evaluate(
    policy: Any,
    suite: Suite = SUITE,
    out: str | os.PathLike[str] = "out/evaluate",
    *,
    name: str | None = None,
    workers: int = 1,
    progress: bool = True,
    plots: bool = True,
    scorecard: str | os.PathLike[str] | None = None,
    command: str | None = None,
    batch: int = DEFAULT_BATCH,
) -> dict[str, Any]:
    """Evaluate `policy` on `suite`'s test and OOD sets and write its scorecard.

    Args:
        policy: a spec (`"random"`, `"supervisor"`, `"module:factory"`, a train result
            `.json`, an SB3 `.zip`, a learner checkpoint path), an object with `act(obs)` or
            `predict(obs_batch)`, or a mapping `{task name: either}`.
        suite: the suite, or a shortened one (`SUITE.select(episodes=..., tasks=...)`).
        out: folder of the episode logs (`episodes/*.jsonl`) and, by default, the scorecard.
        name: the policy's name in files and scorecards (default: from the spec).
        workers: processes running episodes (1: in this process).
        progress: show a progress bar.
        plots: write the scorecard's plot, `OUT/scorecard_<name>.png`.
        scorecard: the scorecard's path (default `OUT/scorecard_<name>.json`).
        command: the command line recorded in the scorecard.
        batch: episodes stepped together on an id's vector env (FLUIDS), where the policy
            can act on a batch (random, the supervisor, SB3 models, learners, `predict`-only
            objects); 1 runs every episode alone. The rows are the same either way.

    Returns:
        The scorecard (also written to `scorecard`).
    """
    from fluids_bench.algos.results import write_json_atomic

    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers is {workers!r}; allowed: a positive integer")
    if isinstance(batch, bool) or not isinstance(batch, int) or batch < 1:
        raise ValueError(f"batch is {batch!r}; allowed: a positive integer")
    if not isinstance(suite, Suite):
        raise ValueError(f"suite is {type(suite).__name__}; allowed: a fluids_bench Suite")
    name, suite, per_task = _assign(policy, suite, name)
    observation = {t.name: _check_env(name, per_task[t.name], t) for t in suite.tasks}
    sources: dict[tuple[str, str], PolicySource] = {}
    for task in suite.tasks:
        sources[(name, task.name)] = per_task[task.name]
        for ref in REFERENCES:
            sources.setdefault((ref, task.name), PolicySource(ref, ref, ref))
    out = Path(out)
    logs = {p: EpisodeLog(out / "episodes" / f"{p}.jsonl") for p in {name, *REFERENCES}}
    jobs = _jobs(name, suite, observation)
    run_jobs(jobs, sources, logs, workers, progress, batch)

    by_set: dict[tuple[str, str, str], list[dict[str, Any]]] = {}
    for job, _ in jobs:
        by_set.setdefault((job.policy, job.task, job.set), []).append(logs[job.policy].get(job))
    card = scorecards.build(
        name,
        _describe(name, per_task),
        suite,
        lambda p, t, s: by_set[(p, t, s)],
        command,
        observation,
    )
    path = Path(scorecard) if scorecard is not None else out / f"scorecard_{name}.json"
    write_json_atomic(path, card)
    if plots:
        from fluids_bench.benchmark.plots import plot_scorecard

        plot_scorecard(card, out / f"scorecard_{name}.png")
    return card
