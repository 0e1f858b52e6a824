"""Fully supervised FLUIDS episodes: the supervisor drives everyone (quality checks, benchmarks)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from fluids_bench.tasks.fluids.sim.config import SceneConfig
from fluids_bench.tasks.fluids.sim.spawn import spawn
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor, SupervisorConfig


@dataclass(frozen=True)
class EpisodeSummary:
    seed: int
    steps: int
    success: bool  # every agent reached its goal, no collision
    collisions: int
    cars_arrived: int
    cars: int
    timed_out: bool  # ran out of steps (a deadlock, if nothing collided)

    def as_dict(self) -> dict:
        return asdict(self)


def make_world(scene: SceneConfig, seed: int) -> World:
    world = World(scene)
    spawn(world, np.random.default_rng(seed))
    return world


def run_supervised(
    scene: SceneConfig,
    seed: int,
    max_steps: int = 1500,
    config: SupervisorConfig | None = None,
    stop_on_collision: bool = True,
) -> EpisodeSummary:
    """Run one episode with every agent supervised until all arrive (or `max_steps`)."""
    world = make_world(scene, seed)
    sup = DrivingSupervisor(world, config)
    while world.active.any() and world.steps < max_steps:
        sup.step(world)
        if stop_on_collision and world.log:
            break
    cars = int(world.is_car.sum())
    return EpisodeSummary(
        seed=seed,
        steps=world.steps,
        success=bool(world.reached.all() and not world.log),
        collisions=len(world.log),
        cars_arrived=int(world.reached[world.is_car].sum()),
        cars=cars,
        timed_out=bool(world.active.any() and not world.log),
    )
