"""Run independent tasks in parallel with one large shared payload: in-process, a local process
pool, or Ray.

`run_tasks(fn, tasks, shared, ...)` calls `fn(task, shared)` for every task and hands each
`(task, result)` to `on_result` in the calling process as soon as it finishes (in
completion order). `fn` must be a module-level function; `shared` (here: the policy under
evaluation, tens of MB) is sent to each worker once, not with every task:

* `"process"` with `workers == 1`: a plain loop in this process;
* `"process"`: a `ProcessPoolExecutor` of `workers` processes
  started with `start_method` (`"forkserver"`, whose server imports `fn`'s module once,
  or `"spawn"`; never `fork`); each worker unpickles `shared` once in its initializer;
* `"ray"`: one Ray task per task, at most `workers` in flight, `shared` put in the object
  store once; on the Ray instance already initialised, else on the cluster at `address`, else
  on a local instance started (and stopped) here with `workers` CPUs. Ray is the `ray`
  extra; without it an ImportError names `pip install "fluids-bench[ray]"`.

`TaskSession` keeps the workers (and so each worker's env) for several batches, each
with its own shared payload: the algorithm layer's rollouts, one batch per iteration.

The bounded submission loop and the Ray import are shared with
`fluids_bench.data.collect`, whose pool and Ray runners are tied to per-episode tasks that
return whole trajectories (and would pickle the policy with every episode).
"""

from __future__ import annotations

import contextlib
import os
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
    """Call `fn(task, shared)` for every task; `on_result(task, result)` as each finishes."""
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


class TaskSession:
    """Workers kept for several batches of tasks, each batch with its own shared payload.

    `run_tasks` starts its workers for one batch and hands them one payload for good; an
    algorithm runs a batch of rollouts per iteration with a new policy each time, and starting
    a pool (and each worker's env, and its compiled kernels) per iteration would cost more than
    the rollouts. Used as `with TaskSession(backend, workers, address) as session:`, then
    `session.run(fn, tasks, shared, on_result)` per batch, with `run_tasks`'s meaning:

    * `"process"` with `workers == 1`: a plain loop in this process, nothing started;
    * `"process"`: one `process_pool` for the whole session (its
      fork server imports `preload` once). A batch's payload is pickled once and travels
      with each of its tasks; a worker unpickles it once per batch;
    * `"ray"`: one `ray_session` for the whole session; a
      batch's payload is put in the object store once.

    Leaving the block by an exception (Ctrl-C included) stops the workers at once (see
    `fluids_bench.core.pool`); a finished batch has no task left in flight.
    """

    def __init__(
        self,
        backend: str = "process",
        workers: int = 1,
        address: str | None = None,
        *,
        start_method: str = "forkserver",
        preload: tuple[str, ...] = (),
    ) -> None:
        check_choice("TaskSession", "backend", backend, BACKENDS)
        check_choice("TaskSession", "start_method", start_method, START_METHODS)
        check_int("TaskSession", "workers", workers, 1)
        self.backend, self.workers, self.address = backend, workers, address
        self.start_method, self.preload = start_method, tuple(preload)
        self._stack = contextlib.ExitStack()
        self._pool: Any = None
        self._ray: Any = None
        self._remote: Any = None
        self._batches = 0

    def __enter__(self) -> TaskSession:
        if self.backend == "ray":
            self._ray = self._stack.enter_context(ray_session(self.workers, self.address))
            self._remote = self._ray.remote(num_cpus=1)(_call)
        elif self.workers > 1:
            self._pool = self._stack.enter_context(
                process_pool(self.workers, self.start_method, self.preload)
            )
        return self

    @property
    def local(self) -> bool:
        """Whether batches run in this process (`"process"` with one worker)."""
        return self.backend == "process" and self.workers == 1

    def __exit__(self, *exc_info: Any) -> bool | None:
        self._pool = self._ray = self._remote = None
        return self._stack.__exit__(*exc_info)

    def run(self, fn: TaskFn, tasks: Iterable[Any], shared: Any, on_result: ResultFn) -> None:
        """Call `fn(task, shared)` for every task; `on_result(task, result)` in this process
        as each finishes (completion order)."""
        self._batches += 1
        if self._ray is not None:
            shared_ref = self._ray.put(shared)
            remote = self._remote
            for result in ray_results(
                self._ray, lambda task: remote.remote(fn, task, shared_ref), tasks, self.workers
            ):
                on_result(*result)
        elif self._pool is not None:
            payload = pickle.dumps(shared, protocol=pickle.HIGHEST_PROTOCOL)
            batch = (os.getpid(), self._batches)
            pool = self._pool

            def wait_any(pending: set) -> tuple[set, set]:
                finished, rest = wait(pending, return_when=FIRST_COMPLETED)
                return set(finished), set(rest)

            def submit(task: Any) -> Any:
                return pool.submit(_call_with_batch_payload, fn, task, batch, payload)

            for future in _bounded(submit, tasks, 2 * self.workers, wait_any):
                on_result(*future.result())
        else:
            for task in tasks:
                on_result(task, fn(task, shared))


_BATCH: tuple[Any, Any] = (None, None)  # a session worker's (batch id, unpickled payload)


def _call_with_batch_payload(fn: TaskFn, task: Any, batch: Any, payload: bytes) -> tuple[Any, Any]:
    global _BATCH
    if _BATCH[0] != batch:
        _BATCH = (batch, pickle.loads(payload))
    return task, fn(task, _BATCH[1])
