"""Initial states: where agents start and which route they take (the behaviour level's draw).

Cars start on entry lanes in fixed slots spaced a car length plus a gap apart, so spawns never
overlap; the lane is uniform over entry lanes (ch. 7) and the route uniform over the lane's
movements (every other arm). Pedestrians start on distinct points of their walks' first leg.
"""

from __future__ import annotations

import functools

import numpy as np

from fluids_bench.tasks.fluids.sim.world import World

CAR_GAP = 3.5  # m between consecutive cars' bumpers at spawn
PED_SPACING = 1.5  # m between pedestrians' spawn points on one walk


def _car_slots(world: World) -> tuple[tuple[int, float], ...]:
    """(entry lane index, s of the car's centre) for every spawn slot, nearest the junction first."""
    return _slots(world.layout, float(world.scene.car.length))


@functools.lru_cache(maxsize=64)
def _slots(layout, length: float) -> tuple[tuple[int, float], ...]:
    slots = []
    for e in range(len(layout.entry_lanes)):
        enter = float(layout.routes.enter_s[layout.routes_from_entry(e)[0]])
        s = enter - length / 2 - 1.0
        while s - length / 2 >= 0.0:
            slots.append((e, s))
            s -= length + CAR_GAP
    return tuple(slots)


def capacity(world: World) -> tuple[int, int]:
    """How many cars and pedestrians this world's layout can hold at spawn."""
    walks = world.layout.routes.walk_routes
    per_walk = int(4.0 // PED_SPACING) + 1
    return len(_car_slots(world)), len(walks) * per_walk


def spawn(world: World, rng: np.random.Generator) -> None:
    """Place every agent of `world` at a random non-overlapping start, at rest."""
    max_cars, max_peds = capacity(world)
    n_cars = int(world.is_car.sum())
    n_peds = world.n - n_cars
    if n_cars > max_cars:
        raise ValueError(
            f"num_cars is {n_cars}; the '{world.layout.name}' layout holds at most {max_cars}"
        )
    if n_peds > max_peds:
        raise ValueError(
            f"num_pedestrians is {n_peds}; the '{world.layout.name}' layout holds at most {max_peds}"
        )
    slots = _car_slots(world)
    layout = world.layout
    # lane uniform, then a free slot on it: draw lanes until each car has a slot
    free = {e: [s for (ee, s) in slots if ee == e] for e in range(len(layout.entry_lanes))}
    for agent in range(n_cars):
        lanes = [e for e, ss in free.items() if ss]
        e = lanes[int(rng.integers(len(lanes)))]
        s = free[e].pop(int(rng.integers(len(free[e]))))
        routes = layout.routes_from_entry(e)
        world.place(agent, int(routes[int(rng.integers(len(routes)))]), s)
    walks = layout.routes.walk_routes
    if n_peds:
        per_walk = int(4.0 // PED_SPACING) + 1
        choice = rng.choice(len(walks) * per_walk, size=n_peds, replace=False)
        for agent, c in zip(range(n_cars, world.n), choice, strict=True):
            world.place(agent, int(walks[c // per_walk]), (c % per_walk) * PED_SPACING)
