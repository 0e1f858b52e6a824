"""Run independent tasks in parallel with one large shared payload: in-process, a local process
pool, or Ray.

``run_tasks(fn, tasks, shared, ...)`` calls ``fn(task, shared)`` for every task and hands each
``(task, result)`` to ``on_result`` in the calling process as soon as it finishes (in
completion order). ``fn`` must be a module-level function; ``shared`` (here: the policy under
evaluation, tens of MB) is sent to each worker once, not with every task:

* ``"process"`` with ``workers == 1``: a plain loop in this process;
* ``"process"``: a :class:`~concurrent.futures.ProcessPoolExecutor` of ``workers`` processes
  started with ``start_method`` (``"forkserver"``, whose server imports ``fn``'s module once,
  or ``"spawn"``; never ``fork``); each worker unpickles ``shared`` once in its initializer;
* ``"ray"``: one Ray task per task, at most ``workers`` in flight, ``shared`` put in the object
  store once; on the Ray instance already initialised, else on the cluster at ``address``, else
  on a local instance started (and stopped) here with ``workers`` CPUs. Ray is the ``ray``
  extra; without it an ImportError names ``pip install "fluids-bench[ray]"``.

The bounded submission loop and the Ray import are shared with
:mod:`fluids_bench.data.collect`, whose pool and Ray runners are tied to per-episode tasks that
return whole trajectories (and would pickle the policy with every episode).
"""

from __future__ import annotations

import pickle
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, wait
from typing import Any

from fluids_bench.core.pool import process_pool
from fluids_bench.core.validation import check_choice, check_int
from fluids_bench.data.collect import BACKENDS, START_METHODS, _bounded, ray_results, ray_session

TaskFn = Callable[[Any, Any], Any]
ResultFn = Callable[[Any, Any], None]

_SHARED: Any = None  # a pool worker's copy of the shared payload


def _init_worker(payload: bytes) -> None:
    global _SHARED
    _SHARED = pickle.loads(payload)


def _call_with_worker_shared(fn: TaskFn, task: Any) -> tuple[Any, Any]:
    return task, fn(task, _SHARED)


def _call(fn: TaskFn, task: Any, shared: Any) -> tuple[Any, Any]:
    return task, fn(task, shared)


def run_tasks(
    fn: TaskFn,
    tasks: Iterable[Any],
    shared: Any,
    on_result: ResultFn,
    *,
    backend: str = "process",
    workers: int = 1,
    address: str | None = None,
    start_method: str = "forkserver",
) -> None:
    """Call ``fn(task, shared)`` for every task; ``on_result(task, result)`` as each finishes."""
    check_choice("run_tasks", "backend", backend, BACKENDS)
    check_choice("run_tasks", "start_method", start_method, START_METHODS)
    check_int("run_tasks", "workers", workers, 1)
    if backend == "ray":
        _run_ray(fn, tasks, shared, on_result, workers, address)
    elif workers == 1:
        for task in tasks:
            on_result(task, fn(task, shared))
    else:
        _run_pool(fn, tasks, shared, on_result, workers, start_method)


def _run_pool(
    fn: TaskFn,
    tasks: Iterable[Any],
    shared: Any,
    on_result: ResultFn,
    workers: int,
    start_method: str,
) -> None:
    payload = pickle.dumps(shared, protocol=pickle.HIGHEST_PROTOCOL)
    # the fork server imports fn's module once; workers exit with this process (core.pool)
    with process_pool(
        workers, start_method, [fn.__module__], initializer=_init_worker, initargs=(payload,)
    ) as pool:

        def wait_any(pending: set) -> tuple[set, set]:
            finished, rest = wait(pending, return_when=FIRST_COMPLETED)
            return set(finished), set(rest)

        def submit(task: Any) -> Any:
            return pool.submit(_call_with_worker_shared, fn, task)

        for future in _bounded(submit, tasks, 2 * workers, wait_any):
            on_result(*future.result())


def _run_ray(
    fn: TaskFn,
    tasks: Iterable[Any],
    shared: Any,
    on_result: ResultFn,
    workers: int,
    address: str | None,
) -> None:
    with ray_session(workers, address) as ray:
        shared_ref = ray.put(shared)  # sent to the cluster once, not with every task
        remote = ray.remote(num_cpus=1)(_call)
        for result in ray_results(
            ray, lambda task: remote.remote(fn, task, shared_ref), tasks, workers
        ):
            on_result(*result)
