"""A step's info, built once for every face, on B worlds' rows or one world's.

Info fields, one meaning each (every env card points here):

* `supervisor_action`: the supervisor's label for the info's car at `action_level` in the
  new state (what it would do there; never an echo of the learner's action).
* `collisions`: this step's new collisions as dicts `{step, a, b, kind}` (agent indices,
  `b = -1` off the road) with their fault labels, that concern the info: in `FLUIDS-v0`
  every collision of the world (with `done_when="all"` any of them ends the episode; the
  ego's have 0 in `a` or `b`), in the multi-agent env those the agent is part of.
* `is_success` (only in the info of an agent's last step): the cars the episode is about
  reached their goals and none of them was ever in a collision (`rules.succeeded`). Those
  cars are the ego in `FLUIDS-v0` with `done_when="ego"`, every car with `done_when="all"`
  (every collision involves a car, so this is also "no collision at all"), and the agent
  itself in the multi-agent env.
* `ego_arrived` (`FLUIDS-v0`) / `arrived` (multi-agent): the info's car reached its goal.
* `route`: the name of the info's car's route.
* `lights` (`FLUIDS-v0`): every light's colour name by light name.
* `ego_ran_red_light`, `ego_failed_to_yield` (`FLUIDS-v0`): the ego's fault tracker's flags.

`ego_info` gives the single-agent envs' fields: for one world (its arrays as they are) a dict
of Python values, as `FluidsEnv` returns it; for B worlds' rows ((B, N) arrays) the same keys
with (B,) arrays (the lights a dict of (B,) arrays), which the vector env lays out in
Gymnasium's batched form. `agent_info` gives the multi-agent env's fields of one agent.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

import numpy as np

from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.tasks.fluids.core.rules import ego_of
from fluids_bench.tasks.fluids.sim.lights import STATE_NAMES


@functools.lru_cache(maxsize=16)
def _colour_table(kinds: tuple[str, ...]) -> np.ndarray:
    """Each light's colour name for each state code, (L, codes), as an object array."""
    codes = 1 + max(code for _, code in STATE_NAMES)
    table = np.empty((len(kinds), codes), dtype=object)
    for (kind, code), name in STATE_NAMES.items():
        for light in np.flatnonzero(np.array(kinds) == kind):
            table[light, code] = name
    return table


@functools.lru_cache(maxsize=16)
def _name_table(names: tuple[str, ...]) -> np.ndarray:
    names_array = np.empty(len(names), dtype=object)
    names_array[:] = names
    return names_array


def light_colours(program, states: np.ndarray) -> dict[str, Any]:
    """`{light name: colour}` of a light program's lights in state codes `states`: one
    world's (L,) gives strings (`describe_states`, cached), B worlds' (B, L) gives (B,)
    object arrays."""
    if states.ndim == 1:
        return program.describe_states(states)
    table = _colour_table(tuple(program.kinds))
    return {light: table[k][states[:, k]] for k, light in enumerate(program.names)}


def route_name(names: Sequence[str], route):
    """The name of route `route` (an int), or (B,) names of (B,) routes."""
    if isinstance(route, np.ndarray):
        return _name_table(tuple(names))[route]
    return names[route]


def _own(flags):
    """A (B,) row's own copy (an info never aliases the batch's arrays); a scalar as it is."""
    return flags.copy() if isinstance(flags, np.ndarray) else flags


def ego_info(
    label: Any,
    collisions: Any,
    reached: np.ndarray,
    route: np.ndarray,
    world,
    ran_red: Any,
    failed_to_yield: Any,
    light_states: np.ndarray,
) -> dict[str, Any]:
    """The info of a single-agent step (see the module's list): `label` and `collisions`
    as the face computed them, `reached` and `route` the agents' flags and routes ((N,) for
    one world, (B, N) rows), `world` any world of the scene (its layout's route names and
    its lights), `ran_red` and `failed_to_yield` the ego's fault tracker flags (Python bools
    for one world, (B,) rows), `light_states` the lights' state codes ((L,) or (B, L))."""
    return {
        SUPERVISOR_ACTION_KEY: label,
        "collisions": collisions,
        "ego_arrived": _own(ego_of(reached)),
        "route": route_name(world.layout.routes.names, ego_of(route)),
        "lights": light_colours(world.lights, light_states),
        "ego_ran_red_light": _own(ran_red),
        "ego_failed_to_yield": _own(failed_to_yield),
    }


def agent_info(label: Any, collisions: list, world, agent: int) -> dict[str, Any]:
    """The info of one agent of the multi-agent env (see the module's list)."""
    return {
        SUPERVISOR_ACTION_KEY: label,
        "collisions": collisions,
        "arrived": bool(world.reached[agent]),
        "route": route_name(world.layout.routes.names, int(world.route[agent])),
    }
