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
        for name in ("steer_kp", "steer_kd", "speed_kp"):
            check_range("PIDConfig", name, getattr(self, name), 0.0, 100.0)
        check_range("PIDConfig", "lookahead_min", self.lookahead_min, 0.1, 50.0)
        if self.assumed_mass is not None:
            check_range("PIDConfig", "assumed_mass", self.assumed_mass, 1.0, 1e5)


def wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


class PIDController:
    """Per-agent PID state (integrators, last errors) for one world."""

    def __init__(self, world: World, config: PIDConfig | None = None) -> None:
        self.config = config or PIDConfig()
        self.reset(world)

    def reset(self, world: World) -> None:
        self.steer_int = np.zeros(world.n)
        self.steer_prev = np.zeros(world.n)
        self.speed_int = np.zeros(world.n)

    def lookahead_points(self, world: World) -> np.ndarray:
        cfg = self.config
        ahead = np.maximum(cfg.lookahead_min, cfg.lookahead_time * world.state[:, 3])
        ahead = np.where(world.is_car, ahead, 0.8)
        pts, _ = world.path_points(np.minimum(world.s + ahead, world.path_len))
        return pts

    def controls(self, world: World, target_speed: np.ndarray,
                 aim: np.ndarray | None = None) -> tuple[np.ndarray, tuple]:
        """Controls (N, 2): [steering ψ (rad), force F (N)] for cars, [heading, accel] for
        pedestrians, and the loop memory to :meth:`commit` if they are executed. ``aim``
        overrides the look-ahead points (N, 2)."""
        cfg = self.config
        aim = self.lookahead_points(world) if aim is None else aim
        x, y, th, v = world.state.T
        desired = np.arctan2(aim[:, 1] - y, aim[:, 0] - x)
        err = wrap(desired - th)
        d_err = (err - self.steer_prev) / world.dt
        integ = self.steer_int + err * world.dt
        max_steer = world.scene.car.max_steer
        steer = np.clip(cfg.steer_kp * err + cfg.steer_ki * integ + cfg.steer_kd * d_err, -max_steer, max_steer)
        v_err = target_speed - v
        v_int = self.speed_int + v_err * world.dt
        accel = np.clip(cfg.speed_kp * v_err + cfg.speed_ki * v_int, -cfg.max_decel, cfg.max_accel)
        car = world.scene.car
        mass = cfg.assumed_mass if cfg.assumed_mass is not None else car.mass
        force = np.clip(accel * mass, -car.max_brake_force, car.max_force)
        ped_accel = np.clip(accel, -world.scene.pedestrian.max_accel, world.scene.pedestrian.max_accel)
        out = np.column_stack([np.where(world.is_car, steer, desired), np.where(world.is_car, force, ped_accel)])
        return out, (err, integ, v_int)

    def commit(self, memory: tuple) -> None:
        """Advance the loops' memory (last error, integrators) after controls were executed."""
        self.steer_prev, self.steer_int, self.speed_int = memory
