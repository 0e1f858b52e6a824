"""Level 1 of the supervisor: which movement (target lane) each car takes.

The source's behaviour planner samples a start lane uniformly and then a target uniformly over
the other approaches, p(l_t | l_g) = 1/(K−1) (ch. 7); `fluids_bench.tasks.fluids.sim.spawn` draws exactly
that. A behaviour-level action picks among the movements of the car's entry lane, in the layout's
order (counter-clockwise from the entry: right, straight, left on a four-way).

The supervisor's behaviour for a car is the movement drawn for it at spawn, and stays so
whatever a learner then chooses: the label is `movement_of` that sampled route, never the
car's current route (which the learner's own previous action set).
"""

from __future__ import annotations

import numpy as np

from fluids_bench.tasks.fluids.sim.world import World


def movement_count(world: World) -> int:
    """The largest number of movements any entry lane offers (the behaviour action's size)."""
    return int(
        max(len(world.layout.routes_from_entry(e)) for e in range(len(world.layout.entry_lanes)))
    )


def movement_of(world: World, route: int) -> int:
    """Index of `route` among the movements of its entry lane."""
    routes = world.layout.routes
    options = world.layout.routes_from_entry(int(routes.entry[route]))
    return int(np.flatnonzero(options == route)[0])


def current_movement(world: World, agent: int) -> int:
    """Index of `agent`'s current route among its entry lane's movements (what it drives now,
    which a behaviour-level learner may have chosen; not the supervisor's label)."""
    return movement_of(world, int(world.route[agent]))
