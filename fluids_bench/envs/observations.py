"""Observation families of FLUIDS-v0, chosen by ``obs_type`` and combinable as a Dict.

Each family is a sensor with a fixed space (built once in the env's ``__init__``) and an
``observe(world, rng)`` that reads the world and draws any noise from ``rng`` (the env's
``np_random``), so seeded episodes stay bit-identical with noise on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from fluids_bench.sim.config import check_range
from fluids_bench.sim.sensors.explicit import ExplicitSensor
from fluids_bench.sim.world import World

OBS_TYPES = ("explicit",)
OBS_BOUND = 1000.0  # explicit observations are clipped to ±this (noise could leave the space)


@dataclass(frozen=True)
class ObservationConfig:
    """Every sensor option the env accepts (all JSON-friendly)."""

    obs_type: str | tuple[str, ...] = "explicit"
    obs_noise: float = 0.0  # explicit: variance of the Gaussian noise
    k_nearest: int = 8  # explicit: other agents listed

    def __post_init__(self) -> None:
        kinds = (self.obs_type,) if isinstance(self.obs_type, str) else tuple(self.obs_type)
        if not kinds or any(k not in OBS_TYPES for k in kinds) or len(set(kinds)) != len(kinds):
            raise ValueError(f"FluidsEnv: field 'obs_type' is {self.obs_type!r}; allowed: one of "
                             f"{list(OBS_TYPES)} or a list of distinct ones")
        object.__setattr__(self, "obs_type", self.obs_type if isinstance(self.obs_type, str) else kinds)
        check_range("FluidsEnv", "obs_noise", self.obs_noise, 0.0, 100.0)
        check_range("FluidsEnv", "k_nearest", self.k_nearest, 0, 64, integer=True)

    @property
    def kinds(self) -> tuple[str, ...]:
        return (self.obs_type,) if isinstance(self.obs_type, str) else self.obs_type


class _Explicit:
    def __init__(self, cfg: ObservationConfig, world: World) -> None:
        self.sensor = ExplicitSensor(cfg.k_nearest, cfg.obs_noise)
        self.space = spaces.Box(-OBS_BOUND, OBS_BOUND, (self.sensor.size,), np.float32)

    def observe(self, world: World, rng: np.random.Generator) -> np.ndarray:
        return np.clip(self.sensor.observe(world, rng), -OBS_BOUND, OBS_BOUND)


_FACTORIES = {"explicit": _Explicit}


class Observer:
    """The env's observation: one family, or a Dict of several (keys are the family names)."""

    def __init__(self, cfg: ObservationConfig, world: World) -> None:
        self.config = cfg
        self.parts = {kind: _FACTORIES[kind](cfg, world) for kind in cfg.kinds}
        self.single = isinstance(cfg.obs_type, str)
        self.space = (next(iter(self.parts.values())).space if self.single
                      else spaces.Dict({k: p.space for k, p in self.parts.items()}))

    def observe(self, world: World, rng: np.random.Generator):
        if self.single:
            return next(iter(self.parts.values())).observe(world, rng)
        return {k: p.observe(world, rng) for k, p in self.parts.items()}
