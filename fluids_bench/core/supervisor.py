"""The supervisor protocol every environment in the suite honours, and a way to bring your own.

An imitation learner needs, in any state it visits, the action the supervisor would take there.
Every env therefore offers two equivalent ways to ask:

* `env.unwrapped.supervisor_action()`: the label for the controlled agent in the current
  state, computed on demand, whoever acted before;
* `info["supervisor_action"]`: the same label, returned by `reset` and every `step` for the
  state the env is now in (the state the next action will be taken from).

Labels live in the env's action space (at the level the user acts at). The supervisor reads the
true state of the simulator, never the observation. A PettingZoo `ParallelEnv` of the suite
answers per agent: `env.supervisor_action(agent)` and `infos[agent]["supervisor_action"]`.

Labels are reproducible from a snapshot. Every env of the suite also offers
`env.unwrapped.snapshot()` (an `EnvSnapshot` in the safe state format of
`fluids_bench.core.snapshot`: arrays and JSON with a versioned header, never a pickle) and
`env.unwrapped.restore(snapshot)` (`RestorableEnv`): restored into another env of
the same id and kwargs (reset with any seed, or never reset), the env continues bit-identically under the same
actions (observations, rewards, terminated/truncated, infos) and `supervisor_action()`
equals the label of the env that drove there. A supervisor's cache must be derivable from the
state; memory a supervisor really has (FLUIDS' velocity planner holds its targets between
replans, Singulation's supervisor its push plan) is part of the snapshot and documented in the
env card ("Snapshots and labels"). `fluids_bench.core.snapshot.snapshot` and
`restore` do the same for a wrapped env, `TimeLimit`'s step
count included.

A supervisor does not have to live in the base env: `supervisor_action` asks through the
wrapper chain (outermost first, as Gymnasium's `get_wrapper_attr` does), and
`SupervisorWrapper` attaches any callable `supervisor(env) -> action` to any env, so
the algorithm layer runs on tasks and experts the suite does not own.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, SupportsFloat, runtime_checkable

import gymnasium as gym

SUPERVISOR_ACTION_KEY = "supervisor_action"


@runtime_checkable
class SupervisedEnv(Protocol):
    """An env that can say what its supervisor would do in the current state."""

    def supervisor_action(self) -> Any:
        """The supervisor's action for the controlled agent in the current state."""
        ...


@runtime_checkable
class RestorableEnv(Protocol):
    """An env whose state can be saved and restored exactly (every env of the suite)."""

    def snapshot(self) -> Any:
        """A copy of the env's state in the safe state format (`to_bytes()` stores it):
        everything its future steps and labels depend on (the simulator, the supervisor's
        memory, episode counters, `np_random`)."""
        ...

    def restore(self, snapshot: Any) -> None:
        """Continue from `snapshot` (or its bytes), taken from an env of the same id and
        kwargs; raises `ValueError` for a snapshot of another id, kwargs or version, or a
        damaged one."""
        ...


def find_supervisor(env: gym.Env) -> Callable[[], Any] | None:
    """The `supervisor_action` method nearest the outside of `env`'s wrapper chain, or None.

    A wrapper that defines `supervisor_action` answers before the envs it wraps (Gymnasium's
    `get_wrapper_attr` order); the base env answers last.
    """
    try:
        method = env.get_wrapper_attr(SUPERVISOR_ACTION_KEY)
    except AttributeError:
        return None
    return method if callable(method) else None


def has_supervisor(env: gym.Env) -> bool:
    """Whether `env` or a wrapper around it implements `supervisor_action()`."""
    return find_supervisor(env) is not None


def supervisor_action(env: gym.Env) -> Any:
    """Ask `env` (wrapped or not) for its supervisor's label in the current state."""
    method = find_supervisor(env)
    if method is None:
        raise TypeError(
            f"{type(env.unwrapped).__name__} has no supervisor: fluids-bench algorithms need an "
            "env (or a wrapper) implementing supervisor_action(); attach one with "
            "fluids_bench.core.supervisor.SupervisorWrapper(env, supervisor)"
        )
    return method()


class SupervisorWrapper(gym.Wrapper):
    """Attach a supervisor to any env: `supervisor(env) -> action` for the current state.

    `supervisor` receives this wrapper (so it can read `env.unwrapped`'s true state) and
    must return an action of the env's action space. The wrapper answers
    `supervisor_action()` and puts the same label in `info["supervisor_action"]` after every
    `reset` and `step`, which is all the algorithm layer needs. Example, a hand-written
    CartPole expert:

        env = SupervisorWrapper(gym.make("CartPole-v1"), lambda e: int(e.unwrapped.state[2] > 0))

    To use it by id (`RunConfig(env_id=...)`), register an entry point that returns the
    wrapped env (a module-level function, so worker processes can import it).
    """

    def __init__(self, env: gym.Env, supervisor: Callable[[gym.Env], Any]) -> None:
        if not callable(supervisor):
            raise ValueError(
                f"SupervisorWrapper: supervisor is {supervisor!r}; allowed: a callable "
                "supervisor(env) -> action"
            )
        super().__init__(env)
        self.supervisor = supervisor

    def supervisor_action(self) -> Any:
        """The attached supervisor's action in the current state."""
        return self.supervisor(self)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        observation, info = self.env.reset(seed=seed, options=options)
        return observation, {**info, SUPERVISOR_ACTION_KEY: self.supervisor_action()}

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        observation, reward, terminated, truncated, info = self.env.step(action)
        return (
            observation,
            reward,
            terminated,
            truncated,
            {**info, SUPERVISOR_ACTION_KEY: self.supervisor_action()},
        )
