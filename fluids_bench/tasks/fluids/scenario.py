"""A FLUIDS scenario, shared by `FLUIDS-v0` and the multi-agent env: an env's checked options
(`fluids_bench.tasks.fluids.config.FluidsConfig`) turned into the scene, supervisor and
observation configs and the compiled layout, and the per-step rules both envs apply to each
controlled car (progress reward, collision penalty, termination, success).

Argument errors name the user's argument (`car_mass`, `planner_period`, `num_cars`), never
an internal config field, and are raised at construction, counts included.

Info fields, one meaning each (both env cards point here):

* `supervisor_action`: the supervisor's label for the info's car at `action_level` in the
  new state (what it would do there; never an echo of the learner's action).
* `collisions`: this step's new collisions as dicts `{step, a, b, kind}` (agent indices,
  `b = -1` off the road) that concern the info: in `FLUIDS-v0` every collision of the
  world (with `done_when="all"` any of them ends the episode; the ego's have 0 in `a` or
  `b`), in the multi-agent env those the agent is part of.
* `is_success` (only in the info of an agent's last step): the cars the episode is about
  reached their goals and none of them was ever in a collision. Those cars are the ego in
  `FLUIDS-v0` with `done_when="ego"`, every car with `done_when="all"` (every collision
  involves a car, so this is also "no collision at all"), and the agent itself in the
  multi-agent env.
* `ego_arrived` (`FLUIDS-v0`) / `arrived` (multi-agent): the info's car reached its goal.
* `route`: the name of the info's car's route.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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

COLLISION_PENALTY = 1.0  # subtracted from a car's reward in a step where it is in a collision
SUCCESS_BONUS = 1.0  # paid on the step that ends an episode (an agent's) with is_success
VIOLATION_PENALTY = 1.0  # a red light run or a failure to yield, once each, when it happens
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


# ---------------------------------------------------------------------- per-step rules
def progress(world: World, agent: int) -> float:
    """Metres of its route `agent` has covered (past the end once it arrived)."""
    if world.reached[agent]:
        return float(world.path_len[agent]) + float(world.offset[agent])
    return float(world.s[agent] + world.offset[agent])  # route_s[agent], without the array


def step_reward(gained: float, route_length: float, collided: bool) -> float:
    """Progress reward: the metres gained this step over the route's length from the start (an
    episode that reaches the goal earns 1 in total), minus the collision penalty."""
    return gained / route_length - (COLLISION_PENALTY if collided else 0.0)


def step_reward_v1(
    gained: float,
    route_length: float,
    collided: bool,
    violations: int,
    succeeded: bool,
    failure_penalty: float = 1.0,
) -> float:
    """`reward_version=1`: the progress reward of `step_reward` (1 in total on
    arrival), minus `failure_penalty` times `COLLISION_PENALTY` in a step with a collision
    that fails the episode and times `VIOLATION_PENALTY` for each rule the step broke that
    fails `is_success` (a red light run, a failure to yield), plus `SUCCESS_BONUS` on the
    step that ends the episode with `is_success`. A successful episode returns at least 2
    (1 + the overshoot past the goal, + 1); a failed one at most the progress made (1 plus that
    overshoot)."""
    collision = failure_penalty * COLLISION_PENALTY if collided else 0.0
    return (
        gained / route_length
        - collision
        - failure_penalty * VIOLATION_PENALTY * violations
        + (SUCCESS_BONUS if succeeded else 0.0)
    )


def is_success(world: World, cars: np.ndarray | list[int] | int) -> bool:
    """`is_success`: every one of `cars` reached its goal and none was ever in a collision."""
    idx = np.atleast_1d(np.asarray(cars))
    return bool(world.reached[idx].all() and not world.collided[idx].any())
