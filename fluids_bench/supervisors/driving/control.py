"""Level 4 of the supervisor: two PID loops per agent, vectorised over all agents.

Steering tracks the direction to a look-ahead point on the agent's path; force (cars) or
acceleration (pedestrians) tracks the target velocity. Pedestrians turn directly toward the
look-ahead point (point model).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fluids_bench.sim.config import check_range
from fluids_bench.sim.world import World


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


def wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


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
        self.max_steer = car.max_steer
        self.min_ahead = np.where(world.is_car, cfg.lookahead_min, 0.8)
        self.ahead_time = np.where(world.is_car, cfg.lookahead_time, 0.0)
        self.steer_int = np.zeros(world.n)
        self.steer_prev = np.zeros(world.n)
        self.speed_int = np.zeros(world.n)

    def lookahead_points(self, world: World) -> np.ndarray:
        ahead = np.maximum(self.min_ahead, self.ahead_time * world.state[:, 3])
        pts, _ = world.path_points(np.minimum(world.s + ahead, world.path_len))
        return pts

    def controls(self, world: World, target_speed: np.ndarray,
                 aim: np.ndarray | None = None) -> tuple[np.ndarray, tuple]:
        """Controls (N, 2): [steering ψ (rad), force F (N)] for cars, [heading, accel] for
        pedestrians, and the loop memory to :meth:`commit` if they are executed. ``aim``
        overrides the look-ahead points (N, 2)."""
        cfg = self.config
        aim = self.lookahead_points(world) if aim is None else aim
        state = world.state
        desired = np.arctan2(aim[:, 1] - state[:, 1], aim[:, 0] - state[:, 0])
        err = wrap(desired - state[:, 2])
        integ = self.steer_int + err * world.dt
        steer = cfg.steer_kp * err + cfg.steer_kd / world.dt * (err - self.steer_prev)
        if cfg.steer_ki:
            steer += cfg.steer_ki * integ
        v_err = target_speed - state[:, 3]
        v_int = self.speed_int + v_err * world.dt
        accel = cfg.speed_kp * v_err
        if cfg.speed_ki:
            accel += cfg.speed_ki * v_int
        out = np.empty((world.n, 2))
        np.minimum(np.maximum(steer, -self.max_steer), self.max_steer, out=out[:, 0])
        np.copyto(out[:, 0], desired, where=~self.is_car)
        accel = np.minimum(np.maximum(accel, -cfg.max_decel), cfg.max_accel)
        np.minimum(np.maximum(accel * self.gain, self.low), self.high, out=out[:, 1])
        return out, (err, integ, v_int)

    def commit(self, memory: tuple) -> None:
        """Advance the loops' memory (last error, integrators) after controls were executed."""
        self.steer_prev, self.steer_int, self.speed_int = memory
