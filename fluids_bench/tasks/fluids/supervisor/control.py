"""Level 4 of the supervisor: two PID loops per agent, for all agents at once.

Steering tracks the direction to a look-ahead point on the agent's path; force (cars) or
acceleration (pedestrians) tracks the target velocity. Pedestrians turn directly toward the
look-ahead point (point model). The per-agent arithmetic is a compiled loop
(`fluids_bench.tasks.fluids.supervisor.kernels`): a few dozen scalar operations per agent cost
less there than as numpy calls on 16-element arrays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fluids_bench.tasks.fluids.sim.config import check_range
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor import kernels


@dataclass(frozen=True)
class PIDConfig:
    steer_kp: float = 1.6
    steer_ki: float = 0.0
    steer_kd: float = 0.15
    speed_kp: float = 2.0  # 1/s (the velocity planner's projection assumes this gain)
    speed_ki: float = 0.0
    max_accel: float = 2.5  # m/s²
    max_decel: float = 5.0  # m/s²
    lookahead_min: float = 2.5  # m
    lookahead_time: float = 0.5  # s; look-ahead grows with speed
    assumed_mass: float | None = None  # kg the controller believes cars weigh (None: the truth)

    def __post_init__(self) -> None:
        for name in ("steer_kp", "steer_ki", "steer_kd", "speed_kp", "speed_ki"):
            check_range("PIDConfig", name, getattr(self, name), 0.0, 100.0)
        check_range("PIDConfig", "max_accel", self.max_accel, 0.1, 50.0)
        check_range("PIDConfig", "max_decel", self.max_decel, 0.1, 50.0)
        check_range("PIDConfig", "lookahead_min", self.lookahead_min, 0.1, 50.0)
        check_range("PIDConfig", "lookahead_time", self.lookahead_time, 0.0, 10.0)
        if self.assumed_mass is not None:
            check_range("PIDConfig", "assumed_mass", self.assumed_mass, 1.0, 1e5)


class PIDController:
    """Per-agent PID state (last steering error, integrators) for one world."""

    def __init__(self, world: World, config: PIDConfig | None = None) -> None:
        self.config = config or PIDConfig()
        cfg, car, ped = self.config, world.scene.car, world.scene.pedestrian
        self.is_car = world.is_car
        # per-agent limits, so one expression serves cars (force, N) and pedestrians (m/s²)
        mass = cfg.assumed_mass if cfg.assumed_mass is not None else car.mass
        self.gain = np.where(world.is_car, mass, 1.0)  # acceleration → actuator units
        self.low = np.where(world.is_car, -car.max_brake_force, -ped.max_accel)
        self.high = np.where(world.is_car, car.max_force, ped.max_accel)
        self.min_ahead = np.where(world.is_car, cfg.lookahead_min, 0.8)
        self.ahead_time = np.where(world.is_car, cfg.lookahead_time, 0.0)
        self._gains = (
            cfg.steer_kp,
            cfg.steer_ki,
            cfg.steer_kd / world.dt,
            cfg.speed_kp,
            cfg.speed_ki,
        )
        self._limits = (car.max_steer, cfg.max_decel, cfg.max_accel)
        self.steer_int = np.zeros(world.n)
        self.steer_prev = np.zeros(world.n)
        self.speed_int = np.zeros(world.n)

    def lookahead_points(self, world: World) -> np.ndarray:
        """The point (N, 2) of each agent's path it steers toward."""
        return kernels.lookahead_points(
            world.path_z,
            world.s,
            world.state,
            world.path_len,
            self.min_ahead,
            self.ahead_time,
            PATH_SPACING,
        )

    def controls(
        self, world: World, target_speed: np.ndarray, aim: np.ndarray | None = None
    ) -> tuple[np.ndarray, tuple]:
        """Controls (N, 2): [steering ψ (rad), force F (N)] for cars, [heading, accel] for
        pedestrians, and the loop memory to `commit` if they are executed. `aim`
        overrides the look-ahead points (N, 2)."""
        if aim is None:  # the look-ahead points and the loops in one compiled call
            out, err, integ, v_int = kernels.pid_follow(
                world.path_z, world.s, world.path_len, self.min_ahead, self.ahead_time,
                PATH_SPACING, world.state, self.is_car, target_speed, self.steer_prev,
                self.steer_int, self.speed_int, world.dt, self._gains, self._limits, self.gain,
                self.low, self.high,
            )  # fmt: skip
        else:
            out, err, integ, v_int = kernels.pid_controls(
                world.state, aim, self.is_car, target_speed, self.steer_prev, self.steer_int,
                self.speed_int, world.dt, self._gains, self._limits, self.gain, self.low,
                self.high,
            )  # fmt: skip
        return out, (err, integ, v_int)

    def controls_into(
        self, world: World, target_speed: np.ndarray, out: np.ndarray, memory: np.ndarray
    ) -> None:
        """`controls` toward the look-ahead points, written into `out` (N, 2) and
        `memory` (3, N)."""
        kernels.pid_follow_into(
            world.path_z, world.s, world.path_len, self.min_ahead, self.ahead_time, PATH_SPACING,
            world.state, self.is_car, target_speed, self.steer_prev, self.steer_int,
            self.speed_int, world.dt, self._gains, self._limits, self.gain, self.low, self.high,
            out, memory,
        )  # fmt: skip

    def commit(self, memory: tuple) -> None:
        """Advance the loops' memory (last error, integrators) after controls were executed;
        in place, so that a batch's rows stay bound to them."""
        self.steer_prev[:], self.steer_int[:], self.speed_int[:] = memory
