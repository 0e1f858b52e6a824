"""Observation families of FLUIDS-v0, chosen by `obs_type` and combinable as a Dict.

Each family is a sensor with a fixed space (built once in the env's `__init__`) and an
`observe(world, rng)` that reads the world and draws any noise from `rng` (the env's
`np_random`), so seeded episodes stay bit-identical with noise on.

Families (ch. 7 of the source):

* `"explicit"`: the true state, a flat float32 vector (`fluids_bench.tasks.fluids.sim.sensors.explicit`).
* `"birdseye"`: a top-down RGB image, uint8 (H, W, 3) (`fluids_bench.tasks.fluids.sim.sensors.birdseye`).
* `"qlidar"`: quasi-LIDAR, float32 (m, 4) rows [d, label, ψ_r, v_r], one per ray
  (`fluids_bench.tasks.fluids.sim.sensors.qlidar`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from fluids_bench.core.validation import check_choice, check_float, check_int
from fluids_bench.tasks.fluids.sim.config import check_range
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.sim.sensors.explicit import ExplicitSensor, fill_explicit_worlds
from fluids_bench.tasks.fluids.sim.world import World

OBS_TYPES = ("explicit", "birdseye", "qlidar")
BIRDSEYE_FRAMES = ("ego", "ego_rotated", "global")
OBS_SCALES = ("physical", "normalized")
OBS_BOUND = 1000.0  # explicit observations are clipped to ±this (noise could leave the space)


def _obs_type(where: str, obs_type) -> str | tuple[str, ...]:
    """`obs_type` checked: a family name, or a tuple of distinct ones (from any sequence)."""
    kinds = (obs_type,) if isinstance(obs_type, str) else obs_type
    try:
        kinds = tuple(kinds)
    except TypeError:
        kinds = ()
    if (
        not kinds
        or any(not isinstance(k, str) or k not in OBS_TYPES for k in kinds)
        or len(set(kinds)) != len(kinds)
    ):
        raise ValueError(
            f"{where}: field 'obs_type' is {obs_type!r}; allowed: one of {list(OBS_TYPES)} or "
            "a list of distinct ones"
        )
    return obs_type if isinstance(obs_type, str) else kinds


# sensor option -> (integer?, low, high): the documented ranges, checked for every env
SENSOR_RANGES: dict[str, tuple[bool, float, float]] = {
    "obs_noise": (False, 0.0, 100.0),
    "k_nearest": (True, 0, 64),
    "birdseye_size": (True, 64, 512),
    "birdseye_fov": (False, 5.0, 1000.0),
    "pixel_noise": (False, 0.0, 10000.0),
    "lidar_rays": (True, 1, 4096),
    "lidar_range": (False, 1.0, 1000.0),
    "lidar_noise": (False, 0.0, 100.0),
    "lidar_dropout": (False, 0.0, 1.0),
    "lidar_version": (True, 0, 1),
}


@dataclass(frozen=True)
class ObservationConfig:
    """Every sensor option the env accepts (all JSON-friendly). Units: metres, variances in the
    observation's own units squared (pixel values² for `pixel_noise`)."""

    obs_type: str | tuple[str, ...] = "explicit"
    obs_noise: float = 0.0  # explicit: variance of the Gaussian noise
    k_nearest: int = 8  # explicit: other agents listed
    birdseye_size: int = 84  # birdseye: image height = width (pixels)
    birdseye_fov: float = 40.0  # birdseye: side of the square seen (m), ego frames only
    birdseye_frame: str = "ego"  # birdseye: "ego", "ego_rotated" or "global"
    pixel_noise: float = 0.0  # birdseye: λ_p, variance of the per-pixel Gaussian noise
    lidar_rays: int = 64  # qlidar: m rays, 2πk/m from the ego's heading
    lidar_range: float = 30.0  # qlidar: m
    lidar_noise: float = 0.0  # qlidar: λ_l, variance of the noise on d, ψ_r and v_r
    lidar_dropout: float = 0.0  # qlidar: ε, probability that a ray reads as empty
    lidar_version: int = 0  # qlidar: 1 adds lights' stop lines, occupied crosswalks, goal row
    obs_scale: str = "physical"  # "normalized": explicit and qlidar as flat vectors in [-1, 1]

    def __post_init__(self) -> None:
        object.__setattr__(self, "obs_type", _obs_type("ObservationConfig", self.obs_type))
        check_choice("ObservationConfig", "birdseye_frame", self.birdseye_frame, BIRDSEYE_FRAMES)
        check_choice("ObservationConfig", "obs_scale", self.obs_scale, OBS_SCALES)
        for name, (integer, lo, hi) in SENSOR_RANGES.items():
            check_range("ObservationConfig", name, getattr(self, name), lo, hi, integer=integer)

    @classmethod
    def from_kwargs(cls, where: str, obs_type, options: dict) -> ObservationConfig:
        """The config of an env's `obs_type` and sensor options, checked with errors naming
        `where`; numpy scalars become the Python numbers they hold."""
        values = {}
        for name, value in options.items():
            if name in SENSOR_RANGES:
                integer, lo, hi = SENSOR_RANGES[name]
                value = (check_int if integer else check_float)(where, name, value, lo, hi)
            elif name == "birdseye_frame":
                check_choice(where, name, value, BIRDSEYE_FRAMES)
            elif name == "obs_scale":
                check_choice(where, name, value, OBS_SCALES)
            values[name] = value
        return cls(obs_type=_obs_type(where, obs_type), **values)

    @property
    def kinds(self) -> tuple[str, ...]:
        return (self.obs_type,) if isinstance(self.obs_type, str) else self.obs_type


class _Normalizer:
    """`obs_scale="normalized"`: a physical observation mapped affinely, entry by entry, onto
    a flat float32 vector clipped to `[-1, 1]`: `(x - offset) * gain`, then an optional
    one-hot expansion of the quasi-LIDAR labels. Picklable, stateless.

    Each step costs a handful of numpy calls into the one array it returns: the arithmetic
    runs in float64 (numpy's loop for float32 and float64 operands) and is rounded to float32
    before the clip, which gives the same bits as clipping first (±1 are float32 numbers and
    the rounding is monotone)."""

    def __init__(self, offset: np.ndarray, gain: np.ndarray, labels: int = 0) -> None:
        self.offset, self.gain, self.labels = offset, gain, labels
        if labels:  # qlidar rows [d, label, psi, v]: the scaled columns, the label values
            rows, shift = gain.reshape(-1, 4), offset.reshape(-1, 4)
            self._d_gain, self._pv_gain = rows[:, 0].copy(), rows[:, 2:4].copy()
            self._d_off, self._pv_off = shift[:, 0].copy(), shift[:, 2:4].copy()
            self._shift = bool(np.any(offset))
            self._values = np.arange(1, labels, dtype=np.float32)

    def __setstate__(self, state: dict) -> None:  # pickles of the earlier, shorter state
        self.__init__(state["offset"], state["gain"], state["labels"])

    def __getstate__(self) -> dict:
        return {"offset": self.offset, "gain": self.gain, "labels": self.labels}

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        if not self.labels:
            out = np.empty(obs.shape, np.float32)
            np.multiply(np.subtract(obs, self.offset, dtype=np.float64), self.gain, out=out)
            return _clip_unit(out)
        rays = len(self._d_gain)  # one observation (R, 4) or a batch's rows (B, R, 4)
        rows = obs.reshape(-1, rays, 4)  # -> [d, psi, v, one-hot(label 1..L-1)] per ray
        out = np.empty((len(rows), rays, 2 + self.labels), np.float32)
        d, pv = rows[..., 0], rows[..., 2:4]
        if self._shift:
            d, pv = d - self._d_off, pv - self._pv_off  # float64, as numpy promotes
        np.multiply(d, self._d_gain, out=out[..., 0], dtype=np.float64, casting="same_kind")
        np.multiply(pv, self._pv_gain, out=out[..., 1:3], dtype=np.float64, casting="same_kind")
        _clip_unit(out[..., :3])
        np.equal(np.rint(rows[..., 1:2]), self._values, out=out[..., 3:], casting="unsafe")
        return out.reshape(-1)  # flat, as the space (a batch's caller splits the rows)


def _clip_unit(x: np.ndarray) -> np.ndarray:
    """`x` clipped to `[-1, 1]` in place (NaN stays NaN, as with `np.clip`)."""
    np.minimum(np.maximum(x, -1.0, out=x), 1.0, out=x)
    return x


NEAR = 30.0  # m: the scale of the explicit vector's nearby lengths (the quasi-LIDAR's range)


def explicit_normalizer(k_nearest: int, world: World) -> _Normalizer:
    """The explicit vector's scales: the ego's world position relative to the layout's centre
    over half its extent; the goal's offset and the path left over the layout's extent; the
    other agents' offsets and the distance to the stop line over `NEAR` (30 m: what the
    ego must react to keeps its resolution; farther reads as ±1); speeds over the car's
    `max_speed`; cosines, sines, masks and one-hots as they are."""
    x0, y0, x1, y1 = world.layout.bounds
    extent = max(x1 - x0, y1 - y0)
    v_max = world.scene.car.max_speed
    from fluids_bench.tasks.fluids.sim.sensors.kernels import EGO, GOAL, LIGHT, PER_AGENT

    offset = np.zeros(EGO + GOAL + PER_AGENT * k_nearest + LIGHT)
    gain = np.ones_like(offset)
    offset[:2] = (x0 + x1) / 2, (y0 + y1) / 2
    gain[:2] = 2.0 / extent
    gain[4] = 1.0 / v_max
    gain[EGO : EGO + GOAL] = 1.0 / extent
    for k in range(k_nearest):
        base = EGO + GOAL + PER_AGENT * k
        gain[base : base + 2] = 1.0 / NEAR
        gain[base + 4] = 1.0 / v_max
    gain[-1] = 1.0 / NEAR
    return _Normalizer(offset, gain)


class _Explicit:
    def __init__(self, cfg: ObservationConfig, world: World) -> None:
        self.sensor = ExplicitSensor(cfg.k_nearest, cfg.obs_noise)
        self.batchable = self.sensor.noise_std == 0  # see observe_worlds
        self._raw: np.ndarray | None = None  # observe_worlds' rows, before clipping
        self.raw_space = spaces.Box(-OBS_BOUND, OBS_BOUND, (self.sensor.size,), np.float32)
        self.space, self.scale = self.raw_space, None
        if cfg.obs_scale == "normalized":
            self.scale = explicit_normalizer(cfg.k_nearest, world)
            self.space = spaces.Box(-1.0, 1.0, (self.sensor.size,), np.float32)

    def observe(self, world: World, rng: np.random.Generator) -> np.ndarray:
        return self._finish(self.sensor.observe(world, rng))

    def _finish(self, obs: np.ndarray) -> np.ndarray:
        """Clipped and scaled, elementwise (one observation or rows of several)."""
        obs = np.minimum(np.maximum(obs, -OBS_BOUND, out=obs), OBS_BOUND, out=obs)
        return obs if self.scale is None else self.scale(obs)

    def observe_worlds(self, stepping: np.ndarray, worlds, lights: np.ndarray) -> np.ndarray:
        """`observe` of each world of `worlds` (a
        `WorldBatch`) where `stepping`, as rows
        (noiseless only: a noisy observation draws from each world's own generator)."""
        if self._raw is None or len(self._raw) != len(stepping):
            self._raw = np.zeros((len(stepping), self.sensor.size))
        w, rows, routes = worlds.worlds[0], worlds.rows, worlds.worlds[0].layout.routes
        fill_explicit_worlds(
            self._raw, stepping, rows["state"], rows["active"], w.kind, rows["path_z"],
            rows["path_len"], rows["s"], rows["offset"], w.length, rows["route"], routes.light,
            routes.stop_s, lights, self.sensor.k, PATH_SPACING,
        )  # fmt: skip
        # every world stepped (the usual step): all rows, without a fancy-indexed copy
        rows = self._raw if stepping.all() else self._raw[stepping]
        return self._finish(rows.astype(np.float32))


class _BirdsEye:
    def __init__(self, cfg: ObservationConfig, world: World) -> None:
        from fluids_bench.tasks.fluids.sim.sensors.birdseye import BirdsEyeSensor

        self.sensor = BirdsEyeSensor(
            world.layout, cfg.birdseye_size, cfg.birdseye_fov, cfg.birdseye_frame, cfg.pixel_noise
        )
        self.space = self.raw_space = spaces.Box(0, 255, self.sensor.shape, np.uint8)
        self.scale = None  # an image is already in the form image policies expect

    def observe(self, world: World, rng: np.random.Generator) -> np.ndarray:
        return self.sensor.observe(world, rng)


class _QLidar:
    def __init__(self, cfg: ObservationConfig, world: World) -> None:
        from fluids_bench.tasks.fluids.sim.sensors.qlidar import QLidarSensor

        self.sensor = QLidarSensor(
            world.layout,
            cfg.lidar_rays,
            cfg.lidar_range,
            cfg.lidar_noise,
            cfg.lidar_dropout,
            max_speed=float(world.max_speed.max()),
            version=cfg.lidar_version,
        )
        low, high = self.sensor.bounds
        self.raw_space = spaces.Box(low, high, dtype=np.float32)
        self.space, self.scale = self.raw_space, None
        if cfg.obs_scale == "normalized":
            # d / range in [0, 1], psi / pi, v / (2 v_max); the label one-hot (labels 1 .. L-1)
            labels = len(self.sensor.labels)
            gain = np.tile([1.0 / cfg.lidar_range, 1.0, 1.0 / math.pi, 0.0], (low.shape[0], 1))
            gain[:, 3] = 1.0 / high[:, 3]
            self.scale = _Normalizer(np.zeros(low.shape), gain, labels)
            size = low.shape[0] * (3 + labels - 1)
            self.space = spaces.Box(-1.0, 1.0, (size,), np.float32)

        # noiseless: observe_worlds can read a batch in one call (noise draws per world)
        self.batchable = self.sensor.noise_std == 0 and self.sensor.dropout == 0

    def observe(self, world: World, rng: np.random.Generator) -> np.ndarray:
        obs = self.sensor.observe(world, rng)
        return obs if self.scale is None else self.scale(obs)

    def observe_worlds(self, stepping: np.ndarray, worlds, lights: np.ndarray) -> np.ndarray:
        """`observe` of each world of `worlds` where `stepping`, as rows (noiseless
        only, see `batchable`)."""
        obs = self.sensor.cast_worlds(stepping, worlds, lights)[stepping].astype(np.float32)
        if self.scale is None:
            return obs
        return self.scale(obs).reshape(len(obs), -1)  # row by row, flattened per world


_FACTORIES = {"explicit": _Explicit, "birdseye": _BirdsEye, "qlidar": _QLidar}


class Observer:
    """The env's observation: one family, or a Dict of several (keys are the family names)."""

    def __init__(self, cfg: ObservationConfig, world: World) -> None:
        self.config = cfg
        self.parts = {kind: _FACTORIES[kind](cfg, world) for kind in cfg.kinds}
        self.single = isinstance(cfg.obs_type, str)
        self.space = (
            next(iter(self.parts.values())).space
            if self.single
            else spaces.Dict({k: p.space for k, p in self.parts.items()})
        )

    def observe(self, world: World, rng: np.random.Generator):
        if self.single:
            return next(iter(self.parts.values())).observe(world, rng)
        return {k: p.observe(world, rng) for k, p in self.parts.items()}

    @property
    def batchable(self) -> bool:
        """Whether `observe_worlds` can observe a batch of worlds in one call (a single
        noiseless explicit or quasi-LIDAR observation)."""
        return self.single and getattr(next(iter(self.parts.values())), "batchable", False)

    def observe_worlds(self, stepping: np.ndarray, worlds, lights: np.ndarray) -> np.ndarray:
        """`observe` of every world where `stepping` (bool, (B,)), as rows, when
        `batchable`; `lights`: each world's light states (B, L)."""
        return next(iter(self.parts.values())).observe_worlds(stepping, worlds, lights)
