"""FLUIDS' driving score, modelled on the CARLA leaderboard's: the one place its rule lives.

An episode's score is its route completion (the share of the ego's route it covered, in [0, 1])
times a multiplicative penalty: one coefficient per infraction, raised to the number of times it
happened. Every face of FLUIDS (the scalar env, the vector env, the multi-agent env) calls
[`episode_report`][fluids_bench.tasks.fluids.driving_score.episode_report] at an episode's end
and puts what it returns into that step's `info`:

* `info["driving_score"]`: a float in [0, 1];
* `info["route_completion"]`: a float in [0, 1];
* `info["infractions"]`: a dict from each name of `INFRACTIONS` to its count (an int).

| infraction | FLUIDS event | coefficient | CARLA leaderboard 2.x |
|---|---|---|---|
| `pedestrian_collisions` | the car hit a pedestrian | 0.50 | collision with a pedestrian, 0.50 |
| `vehicle_collisions` | the car hit another car | 0.60 | collision with a vehicle, 0.60 |
| `offroad` | the car left the drivable area | 0.65 | collision with a static element (layout), 0.65 |
| `red_lights` | it entered its junction against a red light | 0.70 | red light, 0.70 |
| `failures_to_yield` | it drove onto a crosswalk a pedestrian was on (that it could have stopped for) | 0.70 | failure to yield to an emergency vehicle, 0.70 |
| `timeouts` | the episode hit its step limit before the car arrived | 0.70 | scenario timeout, 0.70 |

Where it differs from the leaderboard's (its `statistics_manager.py`): a FLUIDS episode ends at
the car's first collision (with a car, a pedestrian or the road's edge), so each collision count
is 0 or 1; leaving the road is such a collision (the leaderboard instead scales by the share of
the route driven outside its lanes); failing to yield is to pedestrians on crosswalks, weighted
as the leaderboard's only yield infraction; a timeout costs 0.70 (the leaderboard's route
timeout only ends the route, but one FLUIDS episode is one short scenario, so its scenario
timeout is the closer analogue, and it keeps a policy that stands still from scoring its partial
route for free); there are no stop signs and no minimum-speed rule.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

# infraction -> multiplicative coefficient per occurrence (see the module's table)
PENALTIES: dict[str, float] = {
    "pedestrian_collisions": 0.50,
    "vehicle_collisions": 0.60,
    "offroad": 0.65,
    "red_lights": 0.70,
    "failures_to_yield": 0.70,
    "timeouts": 0.70,
}
INFRACTIONS: tuple[str, ...] = tuple(PENALTIES)
# a collision's kind (sim.collision) -> its infraction
_COLLISION_KINDS = {
    "car-pedestrian": "pedestrian_collisions",
    "car-car": "vehicle_collisions",
    "offroad": "offroad",
}
INFO_KEYS = ("driving_score", "route_completion", "infractions")


def driving_score(route_completion: float, infractions: Mapping[str, int]) -> float:
    """Route completion times the product of each infraction's coefficient to its count.

    Args:
        route_completion: the share of the route covered, in [0, 1].
        infractions: counts by name (names of `INFRACTIONS`; a missing name counts 0).

    Returns:
        The score, in [0, 1].

    Raises:
        ValueError: a completion outside [0, 1], an unknown infraction or a negative count.
    """
    if not 0.0 <= route_completion <= 1.0:
        raise ValueError(f"route_completion is {route_completion!r}; allowed: a number in [0, 1]")
    penalty = 1.0
    for name, count in infractions.items():
        if name not in PENALTIES:
            raise ValueError(f"infractions has {name!r}; allowed: {list(INFRACTIONS)}")
        if int(count) != count or count < 0:
            raise ValueError(f"infractions[{name!r}] is {count!r}; allowed: an integer >= 0")
        penalty *= PENALTIES[name] ** int(count)
    return float(route_completion) * penalty


def route_completion(world, agent: int, route_length: float) -> float:
    """The share of `agent`'s route it covered: 1 once arrived, else 1 less the metres left to
    its route's end over the route's length from where it started, clipped to [0, 1].

    The metres left are the path's length less the progress along the path, both in the
    path's own coordinates: after a recovery the car follows a path (a bridge, then the rest of
    its route) that starts `world.offset` m into the route's coordinates, and its end is the
    route's end."""
    if world.reached[agent]:
        return 1.0
    left = float(world.path_len[agent]) - float(world.s[agent])
    return float(np.clip(1.0 - left / route_length, 0.0, 1.0))


def count_infractions(faults, agent: int, events: Iterable[Any], timed_out: bool) -> dict[str, int]:
    """Each infraction's count in `agent`'s episode, read at its end: its collisions in the
    episode's last step `events` (an episode ends at its car's first collision), the red light
    and the failure to yield the fault tracker recorded, and whether it `timed_out`."""
    counts = dict.fromkeys(INFRACTIONS, 0)
    for e in events:
        if agent in (e.a, e.b):
            counts[_COLLISION_KINDS[e.kind]] += 1
    counts["red_lights"] = int(bool(faults.ran_red[agent]))
    counts["failures_to_yield"] = int(bool(faults.failed_to_yield[agent]))
    counts["timeouts"] = int(bool(timed_out))
    return counts


def episode_report(
    world, faults, agent: int, route_length: float, events: Iterable[Any], timed_out: bool
) -> dict[str, Any]:
    """The `info` entries of `agent`'s episode end (see the module's docstring).

    Args:
        world: the FLUIDS `World` after the episode's last step.
        faults: its `FaultTracker` (red lights, failures to yield).
        agent: the car's index in the world (0: the ego).
        route_length: its route's length from where it started (m).
        events: the collisions of the last step (`World.step`'s).
        timed_out: the episode ended at its step limit, not by terminating.
    """
    completion = route_completion(world, agent, route_length)
    counts = count_infractions(faults, agent, events, timed_out)
    return {
        "driving_score": driving_score(completion, counts),
        "route_completion": completion,
        "infractions": counts,
    }
