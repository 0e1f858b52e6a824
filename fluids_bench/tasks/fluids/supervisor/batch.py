"""The supervisors of B worlds planning and proposing their controls together.

Each supervisor's targets, last proposal and PID memory are rows of batched arrays (as the
worlds' in `WorldBatch`), so
`SupervisorBatch.propose` is `DrivingSupervisor.propose` for many worlds at once:
`kernels.pid_follow_into` on each row, the same arithmetic as alone. `SupervisorBatch.plan` finds the cars off their routes
in every world in one call and runs the velocity planner of every world due to plan in two
(`plan_kernels.plan_head_worlds`, `plan_kernels.plan_tail_worlds`); only recovery
(rare: a car off its route) runs world by world.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fluids_bench.tasks.fluids.sim.batch import Rows, WorldBatch
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.supervisor.kernels import (
    mark_off_route,
    pid_follow_into,
)
from fluids_bench.tasks.fluids.supervisor.plan_kernels import plan_head_worlds, plan_tail_worlds
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor
from fluids_bench.tasks.fluids.supervisor.trajectory import OFF_ROUTE_HEADING, OFF_ROUTE_LATERAL
from fluids_bench.tasks.fluids.supervisor.velocity import CURVE_LOOK_AHEAD

PID_MEMORY = ("steer_prev", "steer_int", "speed_int")


@njit(cache=True, nogil=True)
def mark_off_route_worlds(
    going, lateral, heading_error, active, is_car, max_lateral, max_heading, out, counts
):  # pragma: no cover (compiled)
    """`mark_off_route` on row `b` of the per-world arrays where `going[b]`, into
    `out[b]` and `counts[b]` (0 elsewhere)."""
    for b in range(len(going)):
        counts[b] = 0
        if going[b]:
            counts[b] = mark_off_route(
                lateral[b], heading_error[b], active[b], is_car, max_lateral, max_heading,
                out[b],
            )  # fmt: skip


@njit(cache=True, nogil=True)
def pid_follow_worlds(
    going, path_z, s, path_len, min_ahead, ahead_time, spacing, state, is_car, targets,
    steer_prev, steer_int, speed_int, dt, gains, limits, gain, low, high, out, memory,
):  # fmt: skip  # pragma: no cover (compiled)
    """`pid_follow_into` on row `b` of every per-world array where `going[b]`: the
    controls into `out[b]` and the loops' next memory into `memory[b]` (3, N)."""
    for b in range(len(going)):
        if going[b]:
            pid_follow_into(
                path_z[b], s[b], path_len[b], min_ahead, ahead_time, spacing, state[b], is_car,
                targets[b], steer_prev[b], steer_int[b], speed_int[b], dt, gains, limits, gain,
                low, high, out[b], memory[b],
            )  # fmt: skip


class SupervisorBatch:
    """Row storage for the supervisors of a `WorldBatch`'s worlds, and their batched
    proposal."""

    def __init__(self, supervisors: list[DrivingSupervisor]) -> None:
        self.plans = Rows(supervisors, ("targets", "proposed", "_memory", "behavior_routes"))
        self.memory = Rows([sup.pid for sup in supervisors], PID_MEMORY)
        n = len(supervisors[0].targets)
        # each supervisor's last proposal: its controls (B, N, 2) and the PID memory after
        # them (B, 3, N)
        self.proposed, self.next_memory = self.plans["proposed"], self.plans["_memory"]
        self._off_route = (
            np.zeros((len(supervisors), n), np.bool_),
            np.zeros(len(supervisors), np.int64),
        )

    @property
    def supervisors(self) -> list[DrivingSupervisor]:
        return self.plans.objects

    def bind(self, index: int, supervisor: DrivingSupervisor) -> None:
        """Make `supervisor` the one of world `index` (its values go into its rows)."""
        self.plans.bind(index, supervisor)
        self.memory.bind(index, supervisor.pid)

    def plan(self, going: np.ndarray, worlds: WorldBatch, lights: np.ndarray) -> None:
        """`DrivingSupervisor.plan` of each supervisor where `going`: the cars off
        their routes found in all worlds in one call and recovered world by world (where any),
        then the velocity plan of every world due for one (`plan_velocities`).
        `lights`: each world's light states now (B, L)."""
        supervisors = self.supervisors
        if supervisors[0].config.recovery:
            off, counts = self._off_route
            mark_off_route_worlds(
                going, worlds["lateral_error"], worlds["heading_error"], worlds["active"],
                worlds.worlds[0].is_car, OFF_ROUTE_LATERAL, OFF_ROUTE_HEADING, off, counts,
            )  # fmt: skip
            for i in counts.nonzero()[0].tolist():
                supervisors[i].recover(worlds.worlds[i], np.flatnonzero(off[i]))
        period = supervisors[0].config.velocity.period
        due = np.flatnonzero(going & (worlds.steps % period == 0))
        if len(due):
            self.plan_velocities(due, worlds, lights)

    def plan_velocities(self, due: np.ndarray, worlds: WorldBatch, lights: np.ndarray) -> None:
        """`VelocityPlanner.plan` of the worlds `due` (indices) into their rows of
        `plans`' `targets`: two compiled calls around numpy's abs of all their circle gaps. Every
        world's planner shares the scene's constants (the vector env's worlds are all of one
        scene), so the first world's planner lends them."""
        sup, w = self.supervisors[0], worlds.worlds[0]
        planner = sup.planner
        cfg = planner.config
        planner._bind(w)
        defensive = sup.uncontrolled is not None
        uncontrolled = sup.uncontrolled if defensive else planner._none_uncontrolled
        routes, light_program, cw = w.layout.routes, w.lights, planner._crosswalks
        heads, gaps, starts = plan_head_worlds(
            due, uncontrolled, planner.fractions,
            worlds["state"], worlds["s"], worlds["offset"], planner._front, w.is_car,
            worlds["active"], w.width, worlds["route"], worlds["entered"], w.max_speed,
            planner._brake_limit, routes.curvature, routes.speed_limit, routes.enter_s,
            routes.light, routes.stop_s, planner._across, lights, light_program.ends,
            light_program.cycle, light_program.offset, worlds.times, cw.centre, cw.axis,
            cw.half, cw.car_enter, cw.walk_crosswalk, cw.walk_enter, planner._turns[1],
            planner._offs32, planner._radius, planner._reach, worlds["path_c64"],
            worlds["path_dir"], planner._decay, planner._hold_wild, planner._ints,
            planner._floats, CURVE_LOOK_AHEAD, cfg.yield_to_pedestrians, defensive,
        )  # fmt: skip
        failed = plan_tail_worlds(
            due, heads, np.abs(gaps), starts,  # numpy's abs, as alone
            worlds["state"], worlds["s"], worlds["offset"], planner._front, w.is_car,
            worlds["route"], routes.enter_s, planner._offs32, planner._radius, planner._reach,
            worlds["path_c64"], worlds["path_dir"], 1.0 / PATH_SPACING, cfg.margin,
            cfg.pedestrian_margin, self.plans["targets"],
        )  # fmt: skip
        if failed >= 0:  # cannot happen (all-stop is feasible); fail loudly if it does
            raise RuntimeError(
                f"velocity CSP of world {int(due[failed])} has no solution; the all-stop "
                "invariant is broken"
            )

    def propose(self, going: np.ndarray, worlds: WorldBatch) -> None:
        """`DrivingSupervisor.propose` for each world where `going` (bool, (B,)), into
        the supervisors' rows of `proposed` and `next_memory`."""
        self.follow(going, worlds, self.plans["targets"], self.proposed, self.next_memory)

    def follow(
        self,
        mask: np.ndarray,
        worlds: WorldBatch,
        targets: np.ndarray,
        out: np.ndarray,
        memory: np.ndarray,
    ) -> None:
        """`PIDController.controls` toward `targets` (B, N) for each world where `mask`:
        the controls into `out` (B, N, 2), the loops' next memory into `memory` (B, 3, N)."""
        pid, w, rows = self.supervisors[0].pid, worlds.worlds[0], self.memory
        pid_follow_worlds(
            mask, worlds["path_z"], worlds["s"], worlds["path_len"], pid.min_ahead,
            pid.ahead_time, PATH_SPACING, worlds["state"], pid.is_car, targets,
            rows["steer_prev"], rows["steer_int"], rows["speed_int"], w.dt, pid._gains,
            pid._limits, pid.gain, pid.low, pid.high, out, memory,
        )  # fmt: skip

    def commit_proposals(self, mask: np.ndarray) -> None:
        """`DrivingSupervisor.commit()` (of its own proposal's memory) for each supervisor
        where `mask`."""
        for k, name in enumerate(PID_MEMORY):
            self.memory[name][mask] = self.next_memory[mask, k]
