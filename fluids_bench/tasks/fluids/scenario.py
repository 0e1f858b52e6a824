"""A FLUIDS scenario, shared by `FLUIDS-v0` and the multi-agent env: an env's checked options
(`fluids_bench.tasks.fluids.config.FluidsConfig`) turned into the scene, supervisor and
observation configs and the compiled layout. The per-step rules every face applies (progress
reward, collision penalty, termination, success) are in `fluids_bench.tasks.fluids.core.rules`.

Argument errors name the user's argument (`car_mass`, `planner_period`, `num_cars`), never
an internal config field, and are raised at construction, counts included.

Info fields have one meaning each: `fluids_bench.tasks.fluids.core.infos`.
"""

from __future__ import annotations

from dataclasses import dataclass

from fluids_bench.tasks.fluids.config import FluidsConfig
from fluids_bench.tasks.fluids.observations import ObservationConfig
from fluids_bench.tasks.fluids.sim.config import (
    CarConfig,
    PedestrianConfig,
    SceneConfig,
)
from fluids_bench.tasks.fluids.sim.layout.compiled import Layout, compile_layout
from fluids_bench.tasks.fluids.sim.spawn import capacity
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.control import PIDConfig
from fluids_bench.tasks.fluids.supervisor.stack import SupervisorConfig
from fluids_bench.tasks.fluids.supervisor.trajectory import ompl_layout
from fluids_bench.tasks.fluids.supervisor.velocity import VelocityPlannerConfig

ASSUMED_MASS = CarConfig().mass  # kg: the supervisor's PID assumes the default car's mass


@dataclass(frozen=True)
class Scenario:
    """Everything an env builds its world, supervisor and sensors from."""

    scene: SceneConfig
    supervisor: SupervisorConfig
    observation: ObservationConfig
    layout: Layout
    action_level: str


def build_scenario(where: str, config: FluidsConfig, *, multi_agent: bool) -> Scenario:
    """The scenario of a checked `config` (`where` names the env in errors): its layout
    compiled, and the one check that needs it made (the cars fit the layout's entry slots).

    `multi_agent=False` is `FluidsEnv`: one ego car (`controlled_cars` is 1, not a user
    argument). With `defensive`, the supervised agents treat the controlled cars (agents
    `0 .. controlled - 1`) as drivers that may brake at their limit at any time (see
    `SupervisorConfig`); with `yield_to_pedestrians`, supervised cars wait before a
    crosswalk with a pedestrian on it (`domains`)."""
    c = config
    controlled = c.controlled_cars
    car = CarConfig(mass=c.car_mass)
    probe_scene = SceneConfig(
        layout=c.layout, lanes=c.lanes, lights=c.lights, num_cars=1, num_pedestrians=0, dt=c.dt,
        car=car,
    )  # fmt: skip
    spec = probe_scene.layout_spec()
    compiled = ompl_layout(spec, car) if c.trajectory_planner == "ompl" else compile_layout(spec)
    max_cars, max_peds = capacity(World(probe_scene, compiled))
    _check_capacity(
        where, controlled if multi_agent else None, c.num_cars, max_cars, c.layout, c.lanes
    )
    if c.num_pedestrians > max_peds:
        raise ValueError(
            f"{where}: field 'num_pedestrians' is {c.num_pedestrians}; the {c.layout!r} layout "
            f"holds at most {max_peds}"
        )
    scene = SceneConfig(
        layout=c.layout,
        lanes=c.lanes,
        lights=c.lights,
        num_cars=controlled + c.num_cars,
        num_pedestrians=c.num_pedestrians,
        dt=c.dt,
        car=car,
        pedestrian=PedestrianConfig(max_speed=c.pedestrian_speed),
        light_cycle_scale=c.light_cycle_scale,
    )
    supervisor = SupervisorConfig(
        velocity=VelocityPlannerConfig(
            period=c.planner_period, yield_to_pedestrians=c.yield_to_pedestrians
        ),
        pid=PIDConfig(assumed_mass=ASSUMED_MASS),
        waypoints=c.waypoints,
        waypoint_spacing=c.waypoint_spacing,
        uncontrolled=tuple(range(controlled)) if c.defensive else (),
    )
    return Scenario(scene, supervisor, c.observation(), compiled, c.action_level)


def _check_capacity(
    where: str, controlled_cars: int | None, num_cars: int, max_cars: int, layout: str, lanes: int
) -> None:
    lanes_note = "" if layout == "roundabout" else f" with lanes={lanes}"
    holds = f"the {layout!r} layout{lanes_note} holds at most {max_cars} cars"
    if controlled_cars is None:
        if 1 + num_cars > max_cars:
            raise ValueError(
                f"{where}: field 'num_cars' is {num_cars}; {holds}, the ego included: allowed: "
                f"an integer in [0, {max_cars - 1}]"
            )
    elif controlled_cars + num_cars > max_cars:
        raise ValueError(
            f"{where}: controlled_cars + num_cars is {controlled_cars} + {num_cars} = "
            f"{controlled_cars + num_cars}; {holds} (so controlled_cars <= "
            f"{max(max_cars - num_cars, 0)} with num_cars={num_cars})"
        )
