"""Parallel execution for the whole package: process pools, Ray, worker initialisers, claims.

Everything that runs work on several processes goes through this module (the ground floor: it
imports nothing of the package but `fluids_bench.core.validation`), so collect, sweep, train
and evaluate share one pool, one Ray session and one way of stopping:

- [`process_pool`][fluids_bench.core.parallel.process_pool]: a `ProcessPoolExecutor`
  (`"forkserver"` or `"spawn"`) whose workers never outlive the program that started them;
- [`run_tasks`][fluids_bench.core.parallel.run_tasks] and
  [`TaskSession`][fluids_bench.core.parallel.TaskSession]: independent tasks with one shared
  payload, in this process, on a process pool or on Ray, results handed back as they finish;
- [`worker_env`][fluids_bench.core.parallel.worker_env]: the one env per (id, kwargs) a worker
  keeps across its tasks;
- [`as_finished`][fluids_bench.core.parallel.as_finished] and
  [`one_blas_thread`][fluids_bench.core.parallel.one_blas_thread] for the scripts' pools;
- [`claim_dataset`][fluids_bench.core.parallel.claim_dataset]: one writer per dataset id;
- [`interrupted`][fluids_bench.core.parallel.interrupted]: whether an error is Ctrl-C's.

## Process pools

[`process_pool`][fluids_bench.core.parallel.process_pool] has four guarantees a plain
`ProcessPoolExecutor` lacks:

- a worker exits when the program that made the pool dies, even by SIGKILL (which runs no
  clean-up): each worker runs a daemon thread polling that program's pid, and on Linux also
  asks the kernel for SIGKILL when its own parent exits (`PR_SET_PDEATHSIG`). Without this a
  killed `collect --workers 2` left its workers, the fork server and the resource tracker
  running for ever;
- Ctrl-C is the calling program's: workers ignore SIGINT (the terminal sends it to the whole
  process group), so there is one `KeyboardInterrupt`, in the caller, not one traceback per
  worker;
- leaving the block by an exception (Ctrl-C included) cancels the queued tasks, lets each worker
  finish the task it holds for a few seconds, then terminates what is left, instead of
  waiting for every queued task;
- each worker computes with one BLAS thread
  ([`one_blas_thread`][fluids_bench.core.parallel.one_blas_thread]).

## Tasks with a shared payload

`run_tasks(fn, tasks, shared, on_result, ...)` calls `fn(task, shared)` for every task and hands
each `(task, result)` to `on_result` in the calling process as soon as it finishes (in completion
order). `fn` must be a module-level function; `shared` (a policy under evaluation, tens of MB) is
sent to each worker once, not with every task:

- `"process"` with `workers == 1`: a plain loop in this process;
- `"process"`: a [`process_pool`][fluids_bench.core.parallel.process_pool] of `workers`
  processes started with `start_method` (`"forkserver"`, whose server imports `fn`'s module
  once, or `"spawn"`; never `fork`); each worker unpickles `shared` once in its initializer;
- `"ray"`: one Ray task per task, at most `workers` in flight, `shared` put in the object store
  once; on the Ray instance already initialised, else on the cluster at `address`, else on a
  local instance started (and stopped) here with `workers` CPUs. Ray is the `ray` extra; without
  it an ImportError names `pip install "fluids-bench[ray]"`.

[`TaskSession`][fluids_bench.core.parallel.TaskSession] keeps the workers (and so each worker's
env) for several batches, each with its own shared payload: the algorithm layer's rollouts, one
batch per iteration.

## Claims

One writer per dataset id: a claim file created exclusively before collecting. Two
`fluids-bench collect` runs into the same new id both passed the "does it exist?" check (it did
not, yet), both collected, and the second silently replaced the first. A claim closes that window
from the start: `O_CREAT | O_EXCL` is atomic on a local file system (and on NFS v3+), so of two
runs racing for one id exactly one creates the claim and the other is refused before it collects
anything. The claim holds `host pid`; a claim whose process is gone (a run killed with SIGKILL,
which runs no clean-up) is taken over. The export's final rename never replaces a dataset that
appeared meanwhile either (`fluids_bench.data.minari_export`), so the claim is the early refusal
and the rename the guarantee.
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import multiprocessing
import os
import pickle
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, as_completed, wait
from pathlib import Path
from typing import Any
from urllib.parse import quote

from threadpoolctl import threadpool_limits

from fluids_bench.core.validation import check_choice, check_int

BACKENDS = ("process", "ray")
START_METHODS = ("spawn", "forkserver")
RAY_MISSING = 'backend="ray" needs Ray: pip install "fluids-bench[ray]"'
WATCH_INTERVAL = 0.5  # s between two checks of the parent in each worker
STOP_GRACE = 5.0  # s a worker gets to finish its task when the pool is left by an exception
PR_SET_PDEATHSIG = 1  # linux/prctl.h
BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
CLAIMS_DIR = ".fluids-bench-claims"  # hidden: Minari skips dot-folders when listing

TaskFn = Callable[[Any, Any], Any]
ResultFn = Callable[[Any, Any], None]


def pid_alive(pid: int) -> bool:
    """Whether process `pid` is running (a zombie, killed but not yet reaped, is not)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it exists, under another user
        return True
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):  # no /proc (macOS): os.kill's answer stands
        return True


def descendants(pid: int) -> list[int]:
    """Every process below `pid` (children, their children, ...), read from Linux's /proc
    (empty elsewhere): what a clean shutdown must leave behind none of."""
    parents: dict[int, list[int]] = {}
    entries = os.listdir("/proc") if os.path.isdir("/proc") else []
    for entry in entries:
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    parent = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            parents.setdefault(parent, []).append(int(entry))
    out, todo = [], [pid]
    while todo:
        kids = parents.get(todo.pop(), [])
        out += kids
        todo += kids
    return out


def one_blas_thread() -> None:
    """Limit this process's BLAS and OpenMP pools to one thread: where processes are the
    parallelism, a BLAS pool per process oversubscribes the cores, and its threads spin-wait
    against the other workers (an MLP fit of the DART reproduction ran 16x slower with two
    workers on two cores). One thread also makes a worker's floating-point results independent
    of the machine's core count."""
    global _BLAS_LIMITS
    for variable in BLAS_THREAD_VARIABLES:  # for the libraries this process loads later
        os.environ[variable] = "1"
    _BLAS_LIMITS = threadpool_limits(1)  # for those already loaded; holds while the object lives


_BLAS_LIMITS = None


def _watch(pid: int) -> None:
    while pid_alive(pid):
        time.sleep(WATCH_INTERVAL)
    os._exit(1)  # the program that owns this worker is gone: nobody will read our results


def _die_with_parent() -> None:
    """Linux: SIGKILL this process when its parent exits (a no-op elsewhere)."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)


def _init_worker(
    owner: int, initializer: Callable[..., None] | None, initargs: tuple[Any, ...]
) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is handled by the owner
    _die_with_parent()  # the direct parent: the owner (spawn) or the fork server
    threading.Thread(target=_watch, args=(owner,), daemon=True, name="owner-watch").start()
    if not pid_alive(owner):  # died before the thread's first look
        os._exit(1)
    one_blas_thread()
    if initializer is not None:
        initializer(*initargs)


def _terminate(pool: ProcessPoolExecutor) -> None:
    # Cancel what is queued and let each worker finish the task it holds (tasks are short: an
    # episode), for up to STOP_GRACE seconds; only then kill what is left. Killing a worker
    # while it writes its result leaves half a message in the result pipe, and the pool's
    # manager thread, which the interpreter joins at exit, then waits on it for ever.
    # ``_processes`` is private, but the only handle on the workers.
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    deadline = time.monotonic() + STOP_GRACE
    for process in processes:
        with contextlib.suppress(Exception):
            process.join(timeout=max(0.0, deadline - time.monotonic()))
    for process in processes:
        with contextlib.suppress(Exception):
            if process.is_alive():
                process.terminate()
    for process in processes:
        with contextlib.suppress(Exception):
            process.join(timeout=5)


@contextlib.contextmanager
def process_pool(
    workers: int,
    start_method: str,
    preload: Sequence[str] = (),
    initializer: Callable[..., None] | None = None,
    initargs: tuple[Any, ...] = (),
) -> Iterator[ProcessPoolExecutor]:
    """A pool of `workers` processes (see the module docstring). `preload`: modules the
    fork server imports once, before forking workers (`"forkserver"` only)."""
    context = multiprocessing.get_context(start_method)
    if start_method == "forkserver" and preload:
        context.set_forkserver_preload(list(preload))
    pool = ProcessPoolExecutor(
        max_workers=workers,
        mp_context=context,
        initializer=_init_worker,
        initargs=(os.getpid(), initializer, initargs),
    )
    try:
        yield pool
    except BaseException:
        _terminate(pool)
        raise
    pool.shutdown(wait=True)


def as_finished(
    fn: Callable[..., Any], jobs: Sequence[tuple[Any, ...]], workers: int
) -> Iterator[tuple[int, Any]]:
    """`(i, fn(*jobs[i]))` as each job finishes, with one BLAS thread either way (so results
    do not depend on the core count): in this process for one worker (`fn` need not be
    importable by a worker, e.g. a script loaded by path), else in a plain process pool."""
    if workers == 1:
        with threadpool_limits(1):
            yield from ((i, fn(*job)) for i, job in enumerate(jobs))
        return
    with ProcessPoolExecutor(workers, initializer=one_blas_thread) as pool:
        futures = {pool.submit(fn, *job): i for i, job in enumerate(jobs)}
        yield from ((futures[fut], fut.result()) for fut in as_completed(futures))


def interrupted(exc: BaseException | None) -> bool:
    """Whether `exc` is Ctrl-C, or an error that Ctrl-C caused: a KeyboardInterrupt raised
    inside a compiled (numba) kernel comes out as a SystemError chained to it."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


# one env per (id, kwargs) in each worker process, reused across its tasks
_ENVS: dict[tuple[str, str], Any] = {}


def worker_env(env_id: str, env_kwargs: dict[str, Any]) -> Any:
    """This process's env for `env_id` and `env_kwargs` (`gym.make` on first use, then the same
    object: every rollout on it starts from a full reset). The id must be registered in this
    process: the task function's module registers the suite's ids by importing `fluids_bench`."""
    key = (env_id, json.dumps(env_kwargs, sort_keys=True, default=repr))
    if key not in _ENVS:
        import gymnasium as gym  # here: the pool alone (cli, claims) needs no gymnasium

        _ENVS[key] = gym.make(env_id, **env_kwargs)
    return _ENVS[key]


def bounded(
    submit: Callable[[Any], Any],
    tasks: Iterable[Any],
    limit: int,
    wait_any: Callable[[set], tuple[set, set]],
) -> Iterator[Any]:
    """Keep at most `limit` tasks in flight; yield each finished handle."""
    pending: set = set()
    for task in tasks:
        if len(pending) >= limit:
            finished, pending = wait_any(pending)
            yield from finished
        pending.add(submit(task))
    while pending:
        finished, pending = wait_any(pending)
        yield from finished


def _wait_futures(pending: set) -> tuple[set, set]:
    finished, rest = wait(pending, return_when=FIRST_COMPLETED)
    return set(finished), set(rest)


def import_ray():
    """`ray`, or an ImportError naming the extra that installs it."""
    try:
        import ray
    except ImportError as exc:
        raise ImportError(RAY_MISSING) from exc
    return ray


@contextlib.contextmanager
def ray_session(workers: int, address: str | None):
    """Ray, initialised for this block (a cluster at `address`, else a local instance of
    `workers` CPUs) unless it already was; shut down after if this block started it."""
    ray = import_ray()
    started = not ray.is_initialized()
    if started:
        if address is not None:
            ray.init(address=address)
        else:
            ray.init(num_cpus=workers, include_dashboard=False)
    try:
        yield ray
    finally:
        if started:
            ray.shutdown()


def ray_results(ray, submit: Callable[[Any], Any], tasks, workers: int):
    """Results of `submit(task)` remote calls, at most `workers` in flight, as they finish."""

    def wait_any(pending: set) -> tuple[set, set]:
        finished, rest = ray.wait(list(pending), num_returns=1)
        return set(finished), set(rest)

    for ref in bounded(submit, tasks, workers, wait_any):
        yield ray.get(ref)


_SHARED: Any = None  # a pool worker's copy of the shared payload


def _init_shared(payload: bytes) -> None:
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
    # the fork server imports fn's module once; workers exit with this process
    with process_pool(
        workers, start_method, [fn.__module__], initializer=_init_shared, initargs=(payload,)
    ) as pool:

        def submit(task: Any) -> Any:
            return pool.submit(_call_with_worker_shared, fn, task)

        for future in bounded(submit, tasks, 2 * workers, _wait_futures):
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
    `process_pool`); a finished batch has no task left in flight.
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

            for future in bounded(submit, tasks, 2 * self.workers, _wait_futures):
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


def claim_path(root: Path, dataset_id: str) -> Path:
    """The claim file of `dataset_id` under the datasets root (one flat name per id)."""
    return root / CLAIMS_DIR / quote(dataset_id, safe="")


def _owner(path: Path) -> tuple[str, int] | None:
    """`(host, pid)` written in a claim, or None when unreadable (being written, or gone)."""
    try:
        host, pid = path.read_text().split()
        return host, int(pid)
    except (OSError, ValueError):
        return None


def _create(path: Path) -> bool:
    for _ in range(3):
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            break
        except FileExistsError:
            return False
        except FileNotFoundError:
            continue  # another run removed the empty claims folder just now: make it again
    else:
        raise FileNotFoundError(f"could not create the claim {path}")
    with os.fdopen(fd, "w") as handle:
        handle.write(f"{socket.gethostname()} {os.getpid()}\n")
    return True


@contextlib.contextmanager
def claim_dataset(root: Path, dataset_id: str) -> Iterator[Path]:
    """Hold the claim on `dataset_id` for the block; `FileExistsError` naming the process
    that holds it when another live run does."""
    path = claim_path(root, dataset_id)
    if not _create(path):
        owner = _owner(path)
        if owner is not None and owner[0] == socket.gethostname() and not pid_alive(owner[1]):
            path.unlink(missing_ok=True)  # its run was killed: take the claim over
        if not _create(path):
            who = "another run" if owner is None else f"process {owner[1]} on {owner[0]}"
            raise FileExistsError(
                f"dataset {dataset_id!r} is being written by {who} (claim {path}); "
                "wait for it to finish, or choose another dataset id"
            )
    try:
        yield path
    finally:
        path.unlink(missing_ok=True)
        with contextlib.suppress(OSError):
            path.parent.rmdir()  # only when no other run holds a claim
