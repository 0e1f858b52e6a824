"""A local process pool whose workers never outlive the program that started them.

`process_pool` is a `ProcessPoolExecutor` (`"forkserver"` or
`"spawn"`) with three guarantees the plain one lacks:

* a worker exits when the program that made the pool dies, even by SIGKILL (which runs no
  clean-up): each worker runs a daemon thread polling that program's pid, and on Linux also
  asks the kernel for SIGKILL when its own parent exits (`PR_SET_PDEATHSIG`). Without this a
  killed `collect --workers 2` left its workers, the fork server and the resource tracker
  running for ever;
* Ctrl-C is the calling program's: workers ignore SIGINT (the terminal sends it to the whole
  process group), so there is one `KeyboardInterrupt`, in the caller, not one traceback per
  worker;
* leaving the block by an exception (Ctrl-C included) cancels the queued tasks, lets each worker
  finish the task it holds for a few seconds, then terminates what is left, instead of
  waiting for every queued task;
* each worker computes with one BLAS thread (`one_blas_thread`).

`one_blas_thread` is also the `initializer` for the scripts' plain process pools.
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from threadpoolctl import threadpool_limits

WATCH_INTERVAL = 0.5  # s between two checks of the parent in each worker
STOP_GRACE = 5.0  # s a worker gets to finish its task when the pool is left by an exception
PR_SET_PDEATHSIG = 1  # linux/prctl.h
BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


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
    from concurrent.futures import as_completed

    with ProcessPoolExecutor(workers, initializer=one_blas_thread) as pool:
        futures = {pool.submit(fn, *job): i for i, job in enumerate(jobs)}
        yield from ((futures[fut], fut.result()) for fut in as_completed(futures))
