"""FLUIDS batched over worker processes: each of W slices of the worlds is one
`FluidsVectorEnv`, the first in the calling
process and the others in W − 1 worker processes.

`gym.make_vec(id, num_envs=B, vectorization_mode="vector_entry_point", num_workers=W)` builds
it (`num_workers=1`, the default, builds the single-process env). One step sends every worker
its actions, steps the first slice here, then gathers the workers' results, so the W batches
step at once, one per core; beyond that the caller only slices actions and concatenates
results. Observations, rewards, flags and infos are
those of one `FluidsVectorEnv` of B worlds bit for bit: a worker's worlds get the seeds the
single-process env would give them, and the infos of the slices merge into the layout
`VectorEnv._add_info` gives (`merge_infos`).
"""

from __future__ import annotations

import multiprocessing as mp
import signal
import time
import traceback
from typing import Any

import numpy as np
from gymnasium.vector import VectorEnv
from gymnasium.vector.utils import batch_space

from fluids_bench.core.validation import check_int, fail, is_int
from fluids_bench.tasks.fluids.vector.actions import check_batch
from fluids_bench.tasks.fluids.vector.bounds import (
    DEFAULT_WORKER_TIMEOUT,
    check_num_envs,
    check_worker_timeout,
    process_state,
)
from fluids_bench.tasks.fluids.vector.env import (
    AutoresetMode,
    FluidsVectorEnv,
    attribute_values,
    check_reset_mask,
    world_index,
    world_seeds,
)

WHERE = "FluidsVectorEnv"
# how long close() waits for a worker to exit before terminating it (s)
CLOSE_TIMEOUT = 10.0
POLL_INTERVAL = 0.05  # s between two looks at a worker that has not answered yet


def make_vector_env(
    num_envs: int = 1,
    num_workers: int = 1,
    context: str | None = None,
    worker_timeout: float | None = DEFAULT_WORKER_TIMEOUT,
    **kwargs: Any,
) -> VectorEnv:
    """The FLUIDS ids' vector entry point: B worlds in this process (`num_workers=1`; a
    `context` and `worker_timeout` are then unused) or spread over `num_workers` worker
    processes started by `context` (`FluidsWorkerVectorEnv`)."""
    if not is_int(num_workers) or num_workers < 1:
        fail(WHERE, "num_workers", num_workers, "an integer in [1, num_envs]")
    _check_context(context)
    check_worker_timeout(WHERE, worker_timeout)
    if num_workers == 1:
        return FluidsVectorEnv(num_envs=num_envs, **kwargs)
    return FluidsWorkerVectorEnv(
        num_envs=num_envs,
        num_workers=num_workers,
        context=context,
        worker_timeout=worker_timeout,
        **kwargs,
    )


def _check_context(context: Any) -> None:
    methods = mp.get_all_start_methods()
    if context is not None and context not in methods:
        fail(WHERE, "context", context, f"None or one of {methods}")


def split(num_envs: int, num_workers: int) -> list[int]:
    """Where each worker's worlds start, and the end: W + 1 offsets, slices differing in size by
    at most one world (the larger first)."""
    size, extra = divmod(num_envs, num_workers)
    starts = [0]
    for w in range(num_workers):
        starts.append(starts[-1] + size + (w < extra))
    return starts


def merge_infos(parts: list[dict[str, Any]], starts: list[int]) -> dict[str, Any]:
    """One vector info from the infos of consecutive slices of the worlds (slice w: worlds
    `starts[w]` … `starts[w + 1] - 1`): as the single-process env builds it, a key's array
    is typed by the first slice that has it and is zero (`None` for objects) where a slice
    lacks it; its mask `_key` is False there; dicts merge key by key."""
    n = starts[-1]
    keys: dict[str, None] = {}  # in first appearance, slice by slice (as world by world)
    for part in parts:
        keys.update(dict.fromkeys(k for k in part if not k.startswith("_")))
    out: dict[str, Any] = {}
    for key in keys:
        values = [part.get(key) for part in parts]
        first = next(v for v in values if v is not None)
        if isinstance(first, dict):
            out[key] = merge_infos([v if v is not None else {} for v in values], starts)
        elif all(v is not None and v.dtype == first.dtype for v in values):
            out[key] = np.concatenate(values)  # every slice has it (most keys, most steps)
        else:
            array = np.zeros((n, *first.shape[1:]), dtype=first.dtype)
            if array.dtype == object:
                array[:] = None
            for w, value in enumerate(values):
                if value is not None:
                    array[starts[w] : starts[w + 1]] = value
            out[key] = array
        mask = np.zeros(n, dtype=np.bool_)
        for w, part in enumerate(parts):
            if f"_{key}" in part:
                mask[starts[w] : starts[w + 1]] = part[f"_{key}"]
        out[f"_{key}"] = mask
    return out


def _serve(pipe, kwargs: dict[str, Any]) -> None:
    """A worker: builds its FluidsVectorEnv, then answers the parent's commands (a method name
    and its arguments) with ("ok", result) or ("error", exception, traceback) until "close"."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    env = None
    try:
        env = FluidsVectorEnv(**kwargs)
        pipe.send(("ok", (env.single_action_space, env.single_observation_space, env.metadata)))
        while True:
            name, args = pipe.recv()
            if name == "close":
                break
            try:
                result = _run(env, name, args)
            except Exception as error:  # the parent raises it
                pipe.send(("error", error, traceback.format_exc()))
            else:
                pipe.send(("ok", result))
    except Exception as error:  # construction failed
        pipe.send(("error", error, traceback.format_exc()))
    except EOFError:  # the parent went away
        pass
    finally:
        if env is not None:
            env.close()
        pipe.close()


def _run(env: FluidsVectorEnv, name: str, args: tuple) -> Any:
    """One command of the parent on a worker's env."""
    if name == "reset":
        seeds, options = args
        return env.reset(seed=seeds, options=options)
    if name == "call":
        method, positional, keywords = args
        return env.call(method, *positional, **keywords)
    return getattr(env, name)(*args)


class _InProcess:
    """Slice 0, stepped by the calling process while the workers step theirs: a connection
    whose `recv` runs the command `send` left (the parent sends to every worker, then
    gathers from slice 0 first)."""

    def __init__(self, env: FluidsVectorEnv) -> None:
        self.env, self._command = env, None

    def send(self, command: tuple) -> None:
        self._command = command

    def recv(self) -> tuple:
        (name, args), self._command = self._command, None
        try:
            return ("ok", _run(self.env, name, args))
        except Exception as error:
            return ("error", error, "")

    def close(self) -> None:
        self.env.close()


class FluidsWorkerVectorEnv(VectorEnv):
    """B FLUIDS worlds in W slices, each stepped as a `FluidsVectorEnv`, the first by
    this process and the others by W − 1 worker processes; the same API, spaces, metadata and
    results as one `FluidsVectorEnv` of B worlds.

    `num_workers`: slices, this process's included (an integer in [1, num_envs]; the entry
    point builds this class from 2 on); `context`: the
    `multiprocessing` start method (`"fork"`, `"spawn"`, `"forkserver"`; default: the
    platform's). Every other argument is `FluidsVectorEnv`'s and is checked there (its error
    is raised here). Each slice keeps one core busy for the whole step: use at most one per
    core. `close()` (or leaving a `with` block) stops the workers; a worker that died
    raises `RuntimeError` naming it at the next call (within `POLL_INTERVAL`), and so does
    a worker that has not answered a call after `worker_timeout` seconds (None: wait for
    ever; default 600 s, room for a cold compile of the kernels in a spawned worker), e.g. one
    stopped by SIGSTOP. After a call interrupted by Ctrl-C the
    slices may be a step apart: every later call raises `RuntimeError` until the env is
    closed (make a new one).
    """

    def __init__(
        self,
        num_envs: int = 2,
        num_workers: int = 2,
        context: str | None = None,
        worker_timeout: float | None = DEFAULT_WORKER_TIMEOUT,
        max_episode_steps: int | None = None,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        self.num_envs = check_int(WHERE, "num_envs", num_envs, 1)
        self.num_workers = check_int(WHERE, "num_workers", num_workers, 1, self.num_envs)
        _check_context(context)
        self.worker_timeout = check_worker_timeout(WHERE, worker_timeout)
        check_num_envs(WHERE, self.num_envs)  # before starting any worker
        self.starts = split(self.num_envs, self.num_workers)
        self._pipes: list[Any] = []  # worker w's connection (w = 0: this process's slice)
        self._interrupted = False  # a call stopped half-way: the workers are out of step
        self._processes: dict[int, Any] = {}  # the worker processes, by slice
        self.closed = False
        ctx = mp.get_context(context)

        def options(w: int) -> dict[str, Any]:
            return {
                **kwargs,
                "num_envs": self.starts[w + 1] - self.starts[w],
                "max_episode_steps": max_episode_steps,
                "autoreset_mode": autoreset_mode,
                "render_mode": render_mode,
            }

        try:
            self._pipes.append(None)  # slice 0 is built below, while the workers build theirs
            for w in range(1, self.num_workers):
                parent, child = ctx.Pipe()
                process = ctx.Process(
                    target=_serve, args=(child, options(w)), name=f"fluids-worker-{w}", daemon=True
                )
                process.start()
                child.close()
                self._pipes.append(parent)
                self._processes[w] = process
            self._pipes[0] = _InProcess(FluidsVectorEnv(**options(0)))
            self._gather(list(range(1, self.num_workers)))  # built, or their error raised
        except BaseException:
            self.close()
            raise
        first = self._pipes[0].env
        self.config = first.config  # every world's options (FluidsConfig)
        first = (first.single_action_space, first.single_observation_space, first.metadata)
        self.single_action_space, self.single_observation_space, metadata = first
        self.metadata = dict(metadata)
        self.autoreset_mode = metadata["autoreset_mode"]
        self.max_episode_steps = max_episode_steps
        self.render_mode = render_mode
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._obs = None  # the last observations (the worlds a masked reset leaves)
        self._ended = np.zeros(self.num_envs, dtype=np.bool_)  # ended last step (Disabled mode)

    # ------------------------------------------------------------------ Gymnasium API
    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset every world (or those of `options["reset_mask"]`); world i gets the seed the
        single-process env gives it (`seed + i`, or the list's i-th)."""
        seeds = world_seeds(seed, self.num_envs)
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        if mask is not None:
            check_reset_mask(mask, self.num_envs)
        busy = []
        for w, (a, b) in enumerate(self._slices()):
            part = None if mask is None else mask[a:b]
            if part is not None and not part.any():
                continue
            sub = {**options, "reset_mask": part} if part is not None else options
            self._send(w, "reset", (seeds[a:b], sub or None))
            busy.append(w)
        results = dict(zip(busy, self._gather(busy), strict=True))
        idle = [w for w in range(self.num_workers) if w not in results]
        if idle and self._obs is None:  # the worlds no reset has reached yet
            for w in idle:
                self._send(w, "_observations", ())
            results.update({w: (obs, {}) for w, obs in zip(idle, self._gather(idle), strict=True)})
        obs = [
            results[w][0] if w in results else self._slice_obs(w) for w in range(self.num_workers)
        ]
        infos = [results[w][1] if w in results else {} for w in range(self.num_workers)]
        self._obs = self._concat(obs)
        self._ended[mask if mask is not None else slice(None)] = False
        return self._copy_obs(), merge_infos(infos, self.starts)

    def step(self, actions):
        if self._obs is None:
            raise RuntimeError(f"{WHERE}: step() called before reset()")
        actions = check_batch(WHERE, self.single_action_space, self.num_envs, actions)
        if self.autoreset_mode is AutoresetMode.DISABLED and self._ended.any():
            raise RuntimeError(
                f"{WHERE}: world {int(self._ended.argmax())} ended; with autoreset_mode="
                f"{self.autoreset_mode.value!r} reset it with reset(options={{'reset_mask': mask}}) "
                "first"
            )
        for w, (a, b) in enumerate(self._slices()):
            self._send(w, "step", (actions[a:b],))
        parts = self._gather()
        self._obs = self._concat([p[0] for p in parts])
        rewards, terminated, truncated = (np.concatenate([p[k] for p in parts]) for k in (1, 2, 3))
        self._ended = terminated | truncated
        return (
            self._copy_obs(),
            rewards,
            terminated,
            truncated,
            merge_infos([p[4] for p in parts], self.starts),
        )

    def render(self) -> tuple[np.ndarray, ...] | None:
        """One frame per world (`render_mode="rgb_array"`)."""
        frames = self._all("render", ())
        if self.render_mode is None:
            return frames[0]
        return tuple(frame for part in frames for frame in part)

    def close_extras(self, **kwargs: Any) -> None:
        for w, process in self._processes.items():
            pipe = self._pipes[w]
            if process.is_alive():
                try:
                    pipe.send(("close", ()))
                except (BrokenPipeError, OSError):
                    pass
        for process in self._processes.values():
            if process_state(process.pid) == "stopped":  # SIGSTOP: it would never exit
                process.kill()  # SIGKILL is the one signal a stopped process acts on
            process.join(CLOSE_TIMEOUT)
            if process.is_alive():
                process.terminate()
                process.join(CLOSE_TIMEOUT)
            if process.is_alive():
                process.kill()
                process.join()
        for pipe in self._pipes:
            if pipe is not None:
                pipe.close()

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Each world's `name` (called with the arguments if it is a method), as
        `SyncVectorEnv.call` gives it."""
        parts = self._all("call", (name, args, kwargs))
        return tuple(value for part in parts for value in part)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        return self.call(name)

    def set_attr(self, name: str, values: Any) -> None:
        """Set `name` on every world: one value each from a list or tuple of `num_envs`,
        else the same value on all (as `SyncVectorEnv.set_attr`)."""
        values = attribute_values(values, self.num_envs)
        for w, (a, b) in enumerate(self._slices()):
            self._send(w, "set_attr", (name, list(values[a:b])))
        self._gather()

    # ------------------------------------------------------------------ supervisor and state
    def supervisor_action(self) -> np.ndarray:
        """Every world's supervisor label in its current state, batched like
        `info["supervisor_action"]`."""
        return np.concatenate(self._all("supervisor_action", ()))

    def snapshot(self, index: int):
        """World `index`'s state (`FluidsVectorEnv.snapshot`)."""
        w, local = self._owner(index)
        self._send(w, "snapshot", (local,))
        return self._gather([w])[0]

    def restore(self, index: int, snap) -> None:
        """Continue world `index` from `snap` (`FluidsVectorEnv.restore`)."""
        w, local = self._owner(index)
        self._send(w, "restore", (local, snap))
        self._gather([w])
        if self._obs is None:  # a restore counts as a reset, as in FluidsVectorEnv
            self._obs = self._concat(self._all("_observations", ()))

    # ------------------------------------------------------------------ helpers
    def _slices(self) -> list[tuple[int, int]]:
        return list(zip(self.starts[:-1], self.starts[1:], strict=True))

    def _owner(self, index: Any) -> tuple[int, int]:
        """The slice holding world `index`, and the world's index in it."""
        index = world_index(index, self.num_envs)
        w = int(np.searchsorted(self.starts, index, side="right")) - 1
        return w, index - self.starts[w]

    def _send(self, w: int, name: str, args: tuple) -> None:
        if self.closed:
            raise RuntimeError(f"{WHERE}: the env is closed")
        if self._interrupted:
            raise RuntimeError(
                f"{WHERE}: a call was interrupted (Ctrl-C, or a worker that did not answer) while "
                "the workers answered, so their worlds may be a step apart; close() this env and "
                "make a new one"
            )
        try:
            self._pipes[w].send((name, args))
        except (BrokenPipeError, OSError) as error:
            raise RuntimeError(f"{WHERE}: worker {w} is not running ({error})") from None
        except BaseException:
            self._interrupted = True  # sent to some workers only
            raise

    def _gather(self, workers: list[int] | None = None) -> list[Any]:
        """Each worker's answer (all of them, or `workers`'), in order; a worker's exception
        is raised here, as it was raised there."""
        workers = list(range(self.num_workers)) if workers is None else workers
        answers, failure = [], None
        try:
            for w in workers:
                try:
                    self._wait(w)
                    answer = self._pipes[w].recv()
                except EOFError:
                    code = self._processes[w].exitcode
                    error = RuntimeError(f"{WHERE}: worker {w} died (exit code {code})")
                    answer = ("error", error, "")
                if answer[0] == "error" and failure is None:
                    failure = answer
                answers.append(answer[1] if answer[0] == "ok" else None)
        except BaseException:  # Ctrl-C: answers left unread would answer the next call
            self._interrupted = True
            raise
        if failure is not None:  # every answer was read first: the pipes stay in step
            raise failure[1]
        return answers

    def _wait(self, w: int) -> None:
        """Until worker `w` has answered (or died: the pipe then reads EOF); RuntimeError
        naming it after `worker_timeout` seconds without an answer."""
        pipe = self._pipes[w]
        if isinstance(pipe, _InProcess):
            return
        deadline = None if self.worker_timeout is None else time.monotonic() + self.worker_timeout
        while not pipe.poll(POLL_INTERVAL):
            if deadline is not None and time.monotonic() >= deadline:
                process = self._processes[w]
                state = process_state(process.pid)
                raise RuntimeError(
                    f"{WHERE}: worker {w} (pid {process.pid}{', ' + state if state else ''}) "
                    f"has not answered for worker_timeout={self.worker_timeout:g} s; its worlds "
                    f"are {self.starts[w]}..{self.starts[w + 1] - 1}. close() this env and make "
                    "a new one (pass a larger worker_timeout, or None, for slower steps)"
                )

    def _all(self, name: str, args: tuple) -> list[Any]:
        """Every worker's answer to one command."""
        for w in range(self.num_workers):
            self._send(w, name, args)
        return self._gather()

    def _concat(self, parts: list[Any]) -> Any:
        if isinstance(parts[0], dict):
            return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
        return np.concatenate(parts)

    def _slice_obs(self, w: int) -> Any:
        a, b = self.starts[w], self.starts[w + 1]
        if isinstance(self._obs, dict):
            return {key: value[a:b] for key, value in self._obs.items()}
        return self._obs[a:b]

    def _copy_obs(self) -> Any:
        if isinstance(self._obs, dict):
            return {key: value.copy() for key, value in self._obs.items()}
        return self._obs.copy()
