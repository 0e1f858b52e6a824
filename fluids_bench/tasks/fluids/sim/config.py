"""Typed, validated configuration of a FLUIDS scene. SI units throughout.

Every dataclass is frozen and checks itself on creation: a bad value raises `ValueError`
naming the field, the value and the allowed range.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from fluids_bench.core.validation import is_int, is_real


def check_range(owner: str, name: str, value, lo: float, hi: float, integer: bool = False) -> None:
    """Raise ValueError unless `lo <= value <= hi` (and `value` is an integer when
    `integer`). numpy scalars count as the Python numbers they hold; bools count as neither."""
    kind = "an integer" if integer else "a number"
    ok = is_int(value) if integer else is_real(value) and math.isfinite(value)
    if not ok or not lo <= value <= hi:
        raise ValueError(f"{owner}: field '{name}' is {value!r}; allowed: {kind} in [{lo}, {hi}]")


@dataclass(frozen=True)
class CarConfig:
    """A car: kinematic bicycle with a rectangular footprint."""

    length: float = 4.5  # m
    width: float = 1.9  # m
    mass: float = 1500.0  # kg; v' = F / m
    lf: float = 1.3  # m, centre of mass to front axle
    lr: float = 1.4  # m, centre of mass to rear axle
    max_speed: float = 10.0  # m/s
    max_steer: float = 0.7  # rad
    max_force: float = 4500.0  # N, forward
    max_brake_force: float = 9000.0  # N

    def __post_init__(self) -> None:
        for name, lo, hi in (
            ("length", 1.0, 20.0),
            ("width", 0.5, 5.0),
            ("mass", 1.0, 1e5),
            ("lf", 0.1, 10.0),
            ("lr", 0.1, 10.0),
            ("max_speed", 0.5, 60.0),
            ("max_steer", 0.05, 1.5),
            ("max_force", 1.0, 1e6),
            ("max_brake_force", 1.0, 1e6),
        ):
            check_range("CarConfig", name, getattr(self, name), lo, hi)


@dataclass(frozen=True)
class PedestrianConfig:
    """A pedestrian: point model with a square footprint of side `2 * radius`."""

    radius: float = 0.3  # m
    max_speed: float = 1.4  # m/s
    max_accel: float = 1.5  # m/s^2

    def __post_init__(self) -> None:
        for name, lo, hi in (
            ("radius", 0.05, 2.0),
            ("max_speed", 0.1, 5.0),
            ("max_accel", 0.1, 20.0),
        ):
            check_range("PedestrianConfig", name, getattr(self, name), lo, hi)


LAYOUTS = ("four_way", "t_junction", "roundabout")


@dataclass(frozen=True)
class SceneConfig:
    """What a FLUIDS world contains. `num_cars` counts every car, the ego included."""

    layout: str = "four_way"
    lanes: int = 1  # lanes per direction (four_way, t_junction)
    lights: bool = True
    num_cars: int = 4
    num_pedestrians: int = 2
    dt: float = 0.1  # s
    car: CarConfig = field(default_factory=CarConfig)
    pedestrian: PedestrianConfig = field(default_factory=PedestrianConfig)
    light_cycle_scale: float = 1.0  # every light phase's duration (and offset) × this

    def __post_init__(self) -> None:
        if self.layout not in LAYOUTS:
            raise ValueError(
                f"SceneConfig: field 'layout' is {self.layout!r}; allowed: {list(LAYOUTS)}"
            )
        check_range("SceneConfig", "lanes", self.lanes, 1, 2, integer=True)
        if not isinstance(self.lights, bool | np.bool_):
            raise ValueError(
                f"SceneConfig: field 'lights' is {self.lights!r}; allowed: true or false"
            )
        check_range("SceneConfig", "num_cars", self.num_cars, 1, 64, integer=True)
        check_range("SceneConfig", "num_pedestrians", self.num_pedestrians, 0, 32, integer=True)
        check_range("SceneConfig", "dt", self.dt, 0.01, 0.5)
        check_range("SceneConfig", "light_cycle_scale", self.light_cycle_scale, 0.25, 4.0)

    def layout_spec(self):
        """The layout this scene runs on (built, not compiled)."""
        from fluids_bench.tasks.fluids.sim.layout.builders import build_layout

        if self.layout == "roundabout":
            return build_layout("roundabout")
        return build_layout(self.layout, lanes=self.lanes, lights=self.lights)
