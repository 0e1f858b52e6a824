"""The four supervisor levels wired together for every agent of a world.

Each step, `DrivingSupervisor.prepare` reads the true world state (never an observation),
plans any needed recovery paths, runs the velocity planner at its rate and proposes controls for
every agent. The env then overrides what the ego's chosen level decides and executes with
`DrivingSupervisor.execute`. The labels of every level for any agent are read from its plan and
proposal (`fluids_bench.tasks.fluids.core.labels`), so the label is what the supervisor would do
in the current state.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fluids_bench.tasks.fluids.sim.config import check_range
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.control import PIDConfig, PIDController
from fluids_bench.tasks.fluids.supervisor.trajectory import RecoveryPlanner, off_route
from fluids_bench.tasks.fluids.supervisor.velocity import VelocityPlanner, VelocityPlannerConfig

LEVELS = ("behavior", "trajectory", "velocity", "control")


@dataclass(frozen=True)
class SupervisorConfig:
    velocity: VelocityPlannerConfig = field(default_factory=VelocityPlannerConfig)
    pid: PIDConfig = field(default_factory=PIDConfig)
    waypoints: int = 5  # trajectory level: how many points
    waypoint_spacing: float = 2.0  # m between them
    recovery: bool = True  # plan back to the route with OMPL when off it
    # agents that may not follow the plan (the learner's cars): the others drive defensively
    # toward them (VelocityPlanner.defensive_domains); empty: everyone is assumed to follow it
    uncontrolled: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        check_range("SupervisorConfig", "waypoints", self.waypoints, 1, 50, integer=True)
        check_range("SupervisorConfig", "waypoint_spacing", self.waypoint_spacing, 0.5, 20.0)
        for i in self.uncontrolled:
            check_range("SupervisorConfig", "uncontrolled", i, 0, 127, integer=True)


class DrivingSupervisor:
    """Plans for all agents of `world`; holds the planner's and controllers' memory."""

    def __init__(self, world: World, config: SupervisorConfig | None = None) -> None:
        self.config = config or SupervisorConfig()
        self.planner = VelocityPlanner(self.config.velocity)
        self.pid = PIDController(world, self.config.pid)
        self._recovery: RecoveryPlanner | None = None
        # the behaviour level's choice for each agent: the route drawn at spawn (the world is
        # spawned before its supervisor is made); a learner acting at that level changes
        # world.route, never this
        self.behavior_routes = world.route.copy()
        self.targets = np.zeros(world.n)
        # the last proposal: every agent's controls and the PID loops' memory after them (rows:
        # last error, steering integral, speed integral); written in place, so that a batch
        # keeps them as rows of its own arrays (supervisor/batch.py)
        self.proposed = np.zeros((world.n, 2))
        self._memory = np.zeros((3, world.n))
        self.recoveries = 0
        self.uncontrolled = None
        if self.config.uncontrolled:
            self.uncontrolled = np.zeros(world.n, dtype=bool)
            self.uncontrolled[[i for i in self.config.uncontrolled if i < world.n]] = True

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_recovery"] = None  # OMPL objects do not pickle; rebuilt on first need
        return state

    def __setstate__(self, state: dict) -> None:
        memory = state["_memory"]
        if isinstance(memory, tuple):  # pickled before the proposal's memory was one array
            n = len(state["targets"])
            state["_memory"] = np.array(memory, dtype=np.float64) if memory else np.zeros((3, n))
        self.__dict__.update(state)

    def recovery_planner(self, world: World) -> RecoveryPlanner:
        if self._recovery is None:  # OMPL set-up only when first needed
            self._recovery = RecoveryPlanner(world)
        return self._recovery

    def prepare(self, world: World) -> None:
        """Recover off-route cars, re-plan velocities when due, propose every agent's controls."""
        self.plan(world)
        self.propose(world)

    def plan(self, world: World) -> None:
        """The first part of `prepare`: recovery paths, and the velocity plan when due
        (written into `targets` in place)."""
        if self.config.recovery:
            self.recover(world, off_route(world))
        self.plan_velocity(world)

    def recover(self, world: World, agents: np.ndarray) -> None:
        """Plan a path back to its route for each of `agents` (off their routes)."""
        for agent in agents:
            if self.recovery_planner(world).plan(world, int(agent)):
                self.recoveries += 1

    def plan_velocity(self, world: World) -> None:
        """The velocity plan, when the planner's period is due."""
        if world.steps % self.config.velocity.period == 0:
            self.targets[:] = (
                self.planner.plan(world)
                if self.uncontrolled is None
                else self.planner.plan(world, self.uncontrolled)
            )

    def propose(self, world: World) -> None:
        """The rest of `prepare`: every agent's controls toward `targets` (a
        `SupervisorBatch` does this for
        many worlds in one call)."""
        self.pid.controls_into(world, self.targets, self.proposed, self._memory)

    def execute(
        self, world: World, controls: np.ndarray | None = None, memory: tuple | None = None
    ):
        """Step `world` with `controls` (the proposal by default); returns new collisions."""
        return world.step(self.commit(controls, memory))

    def commit(self, controls: np.ndarray | None = None, memory: tuple | None = None):
        """Advance the PID loops' memory for executing `controls` (the proposal by default,
        with its memory) and return the controls to execute."""
        self.pid.commit(self._memory if memory is None else memory)
        return self.proposed if controls is None else controls

    def step(self, world: World):
        """One fully supervised step (every agent follows the supervisor)."""
        self.prepare(world)
        return self.execute(world)
