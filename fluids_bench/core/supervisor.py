"""The supervisor protocol every environment in the suite honours.

An imitation learner needs, in any state it visits, the action the supervisor would take there.
Every env therefore offers two equivalent ways to ask:

* ``env.unwrapped.supervisor_action()``: the label for the controlled agent in the current
  state, computed on demand, whoever acted before;
* ``info["supervisor_action"]``: the same label, returned by ``reset`` and every ``step`` for the
  state the env is now in (the state the next action will be taken from).

Labels live in the env's action space (at the level the user acts at). The supervisor reads the
true state of the simulator, never the observation. A PettingZoo ``ParallelEnv`` of the suite
answers per agent: ``env.supervisor_action(agent)`` and ``infos[agent]["supervisor_action"]``.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import gymnasium as gym

SUPERVISOR_ACTION_KEY = "supervisor_action"


@runtime_checkable
class SupervisedEnv(Protocol):
    """An env that can say what its supervisor would do in the current state."""

    def supervisor_action(self) -> Any:
        """The supervisor's action for the controlled agent in the current state."""
        ...


def supervisor_action(env: gym.Env) -> Any:
    """Ask ``env`` (wrapped or not) for its supervisor's label in the current state."""
    inner = env.unwrapped
    if not isinstance(inner, SupervisedEnv):
        raise TypeError(
            f"{type(inner).__name__} has no supervisor: fluids-bench algorithms need an env "
            "implementing supervisor_action() (see fluids_bench.core.supervisor)"
        )
    return inner.supervisor_action()
