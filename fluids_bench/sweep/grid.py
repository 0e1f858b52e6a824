"""The parameter grid of a sensitivity sweep (ch. 7, "Testing Generalization in FLUIDS").

A `Grid` is the full factorial product of a few `Parameter` value lists; its
configurations are numbered in row-major order of the parameters (the last parameter varies
fastest), and configuration `i` maps to keyword arguments of `FLUIDS-Sensitivity-v0`.

The six parameters of the source, with the default values (4 × 4 × 2 × 2 × 2 × 2 = 256
configurations, the source's count):

========================  ==================  =====================  ===========================
parameter                 default values      env keyword            source range
========================  ==================  =====================  ===========================
`cars`                  2, 3, 4, 5          `num_cars = cars-1`  [2, 5] cars, ego included
`pedestrians`           0, 1, 3, 4          `num_pedestrians`    [0, 4]
`lidar_noise`           0, 1                `lidar_noise`        λ_l in [0, 1] (variance)
`lidar_dropout`         0, 1                `lidar_dropout`      omission probability [0, 1]
`lights`                off, on             `lights`             [0, 1]
`car_mass`              750, 3000 kg        `car_mass`           [0, 200] in its own units
========================  ==================  =====================  ===========================

Pedestrians take `round(linspace(0, 4, 4))`. Car mass: the source sweeps [0, 200] in
unstated units around its nominal car; here source value `s` maps to `750 + 11.25 s` kg,
so [0, 200] is 0.5× to 2× the 1500 kg nominal mass the supervisor's PID assumes (1500 kg is
`s ≈ 66.7`); the two default values are the ends of that range, both a model mismatch.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from fluids_bench.core.validation import fail, is_int, is_real

# name -> (kind, lo, hi, unit/description); lo/hi are the values the env accepts
PARAMETERS: dict[str, tuple[str, float, float, str]] = {
    "cars": ("int", 1, 64, "cars in the scene, ego included"),
    "pedestrians": ("int", 0, 32, "pedestrians"),
    "lidar_noise": ("float", 0.0, 100.0, "quasi-LIDAR noise variance λ_l"),
    "lidar_dropout": ("float", 0.0, 1.0, "quasi-LIDAR omission probability ε"),
    "lights": ("bool", 0, 1, "traffic lights on (1) or off (0)"),
    # the env's range (fluids_bench.tasks.fluids.config.CAR_MASS_RANGE)
    "car_mass": ("float", 500.0, 5000.0, "true car mass, kg (the supervisor assumes 1500)"),
}
ORDER = tuple(PARAMETERS)  # the canonical order of columns and of the row-major numbering

DEFAULT_VALUES: dict[str, tuple[Any, ...]] = {
    "cars": (2, 3, 4, 5),
    "pedestrians": (0, 1, 3, 4),
    "lidar_noise": (0.0, 1.0),
    "lidar_dropout": (0.0, 1.0),
    "lights": (False, True),
    "car_mass": (750.0, 3000.0),
}


def source_mass_to_kg(value: float) -> float:
    """The source's car-mass units ([0, 200]) in kg: 0 -> 750 kg, 200 -> 3000 kg."""
    return 750.0 + 11.25 * float(value)


def _coerce(name: str, value: Any) -> Any:
    kind, lo, hi, _ = PARAMETERS[name]
    where = "Grid"
    if kind == "bool":
        if isinstance(value, bool) or value in (0, 1):
            return bool(value)
        fail(where, name, value, "0/1 or false/true")
    if isinstance(value, bool) or not isinstance(value, int | float):
        fail(where, name, value, f"{'an integer' if kind == 'int' else 'a number'} in [{lo}, {hi}]")
    if kind == "int":
        if float(value) != int(value):
            fail(where, name, value, f"an integer in [{lo}, {hi}]")
        value = int(value)
    else:
        value = float(value)
        if not math.isfinite(value):
            fail(where, name, value, f"a finite number in [{lo}, {hi}]")
    if not lo <= value <= hi:
        fail(where, name, value, f"a value in [{lo}, {hi}]")
    return value


@dataclass(frozen=True)
class Grid:
    """Value lists for every parameter of `PARAMETERS` (strictly increasing, non-empty)."""

    values: Mapping[str, tuple[Any, ...]]

    def __post_init__(self) -> None:
        if not isinstance(self.values, Mapping):
            fail("Grid", "values", self.values, "a mapping of parameter name to values")
        unknown = sorted(set(self.values) - set(PARAMETERS))
        if unknown:
            fail("Grid", "values", unknown, f"parameter names among {list(ORDER)}")
        missing = [name for name in ORDER if name not in self.values]
        if missing:
            fail("Grid", "values", missing, f"values for every parameter of {list(ORDER)}")
        clean: dict[str, tuple[Any, ...]] = {}
        for name in ORDER:
            raw = self.values[name]
            if isinstance(raw, str | bytes) or not isinstance(raw, Sequence) or not raw:
                fail("Grid", name, raw, "a non-empty list of values")
            values = tuple(_coerce(name, v) for v in raw)
            if any(b <= a for a, b in itertools.pairwise(values)):
                fail("Grid", name, list(raw), "distinct values in increasing order")
            clean[name] = values
        object.__setattr__(self, "values", clean)

    @classmethod
    def default(cls) -> Grid:
        return cls(DEFAULT_VALUES)

    @classmethod
    def with_overrides(cls, overrides: Mapping[str, Sequence[Any]]) -> Grid:
        """The default grid with some parameters' values replaced."""
        return cls({**DEFAULT_VALUES, **overrides})

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(self.values[name]) for name in ORDER)

    def __len__(self) -> int:
        return math.prod(self.shape)

    def configuration(self, index: int) -> dict[str, Any]:
        """Parameter values of configuration `index` (row-major, last parameter fastest)."""
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(self):
            fail("Grid", "index", index, f"an integer in [0, {len(self) - 1}]")
        out: dict[str, Any] = {}
        for name, size in zip(reversed(ORDER), reversed(self.shape), strict=True):
            index, position = divmod(index, size)
            out[name] = self.values[name][position]
        return {name: out[name] for name in ORDER}

    def configurations(self) -> Iterator[tuple[int, dict[str, Any]]]:
        for index in range(len(self)):
            yield index, self.configuration(index)

    def normalise(self, name: str, value: Any) -> float:
        """`value` of parameter `name` mapped to [0, 1] by the grid's own range."""
        values = self.values[name]
        lo, hi = float(values[0]), float(values[-1])
        return 0.0 if hi == lo else (float(value) - lo) / (hi - lo)

    def to_dict(self) -> dict[str, list[Any]]:
        """JSON-friendly form (what the result store's manifest records)."""
        return {name: list(self.values[name]) for name in ORDER}

    # the interface shared with KwargGrid (the store, the runner and the plots use only it)
    names = ORDER
    legacy = True

    @property
    def kinds(self) -> dict[str, str]:
        return {name: PARAMETERS[name][0] for name in ORDER}

    def env_kwargs(self, configuration: Mapping[str, Any]) -> dict[str, Any]:
        return env_kwargs(configuration)


def env_kwargs(configuration: Mapping[str, Any]) -> dict[str, Any]:
    """`FLUIDS-Sensitivity-v0` keyword arguments of one configuration."""
    return {
        "num_cars": int(configuration["cars"]) - 1,  # background cars besides the ego
        "num_pedestrians": int(configuration["pedestrians"]),
        "lidar_noise": float(configuration["lidar_noise"]),
        "lidar_dropout": float(configuration["lidar_dropout"]),
        "lights": bool(configuration["lights"]),
        "car_mass": float(configuration["car_mass"]),
    }


def parse_values(text: str) -> tuple[str, list[Any]]:
    """`NAME=V1,V2,...` (the CLI's `--values`) as a name and a list of numbers."""
    name, sep, rest = text.partition("=")
    if not sep or not name.isidentifier():
        raise ValueError(
            f"--values: expected NAME=V1,V2,... with NAME an env keyword argument "
            f"(FLUIDS-Sensitivity ids: {list(ORDER)}); got {text!r}"
        )
    out: list[Any] = []
    raw_items = rest.split(",")
    for item in raw_items:
        item = item.strip().lower()
        if item in ("true", "on", "false", "off"):
            out.append(item in ("true", "on"))
            continue
        try:
            out.append(int(item) if item.lstrip("-").isdigit() else float(item))
        except ValueError:
            if name in PARAMETERS:
                raise ValueError(f"--values {name}: {item!r} is not a number") from None
            if not item.isidentifier():
                raise ValueError(
                    f"--values {name}: {item!r} is neither a number, true/false nor a name"
                ) from None
            out.append(raw_items[len(out)].strip())  # a string value (a layout's name), as typed
    return name, out


# -- any registered id: a grid over its keyword arguments ------------------------------------

KINDS = ("bool", "int", "float", "str")
_BAD_TEXT = set(",\"'\n\r")


def _kind(name: str, raw: Sequence[Any]) -> str:
    """The one kind of a value list (ints and floats mixed are floats)."""
    if all(isinstance(v, bool | np.bool_) for v in raw):
        return "bool"
    if all(isinstance(v, str) for v in raw):
        if any(set(v) & _BAD_TEXT or not v for v in raw):
            fail("KwargGrid", name, list(raw), "non-empty strings without commas or quotes")
        return "str"
    if all(is_int(v) for v in raw):
        return "int"
    if all(is_real(v) for v in raw):
        return "float"
    fail("KwargGrid", name, list(raw), "values of one kind: booleans, numbers or strings")
    raise AssertionError  # fail raises


@dataclass(frozen=True)
class KwargGrid:
    """A full factorial grid over an env's keyword arguments, in the order given (the last one
    varies fastest). Values are checked here for shape (one kind per list, distinct, numbers
    increasing) and by the env itself (`fluids_bench.sweep.run.probe_env`); configuration
    `i` is the env kwargs themselves. Normalised values: numbers map their grid range to
    [0, 1], booleans false/true to 0/1, strings their position in the list to [0, 1]."""

    values: Mapping[str, tuple[Any, ...]]

    legacy = False

    def __post_init__(self) -> None:
        if not isinstance(self.values, Mapping) or not self.values:
            fail("KwargGrid", "values", self.values, "a non-empty mapping of kwarg to values")
        clean: dict[str, tuple[Any, ...]] = {}
        kinds: dict[str, str] = {}
        for name, raw in self.values.items():
            if not isinstance(name, str) or not name.isidentifier():
                fail("KwargGrid", "values", name, "keyword-argument names")
            if isinstance(raw, str | bytes) or not isinstance(raw, Sequence) or not raw:
                fail("KwargGrid", name, raw, "a non-empty list of values")
            kind = kinds[name] = _kind(name, raw)
            convert = {"bool": bool, "int": int, "float": float, "str": str}[kind]
            values = tuple(convert(v) for v in raw)
            if kind == "float" and not all(math.isfinite(v) for v in values):
                fail("KwargGrid", name, list(raw), "finite numbers")
            if kind == "str":
                if len(set(values)) != len(values):
                    fail("KwargGrid", name, list(raw), "distinct values")
            elif any(b <= a for a, b in itertools.pairwise(values)):
                fail("KwargGrid", name, list(raw), "distinct values in increasing order")
            clean[name] = values
        object.__setattr__(self, "values", clean)
        object.__setattr__(self, "_kinds", kinds)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.values)

    @property
    def kinds(self) -> dict[str, str]:
        return dict(self._kinds)  # type: ignore[attr-defined]

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for v in self.values.values())

    def __len__(self) -> int:
        return math.prod(self.shape)

    def configuration(self, index: int) -> dict[str, Any]:
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(self):
            fail("KwargGrid", "index", index, f"an integer in [0, {len(self) - 1}]")
        out: dict[str, Any] = {}
        for name, size in zip(reversed(self.names), reversed(self.shape), strict=True):
            index, position = divmod(index, size)
            out[name] = self.values[name][position]
        return {name: out[name] for name in self.names}

    def configurations(self) -> Iterator[tuple[int, dict[str, Any]]]:
        for index in range(len(self)):
            yield index, self.configuration(index)

    def normalise(self, name: str, value: Any) -> float:
        values = self.values[name]
        if self._kinds[name] == "str":  # type: ignore[attr-defined]
            return 0.0 if len(values) == 1 else values.index(value) / (len(values) - 1)
        lo, hi = float(values[0]), float(values[-1])
        return 0.0 if hi == lo else (float(value) - lo) / (hi - lo)

    def to_dict(self) -> dict[str, list[Any]]:
        return {name: list(values) for name, values in self.values.items()}

    def env_kwargs(self, configuration: Mapping[str, Any]) -> dict[str, Any]:
        return {name: configuration[name] for name in self.names}


# Each task's default sensitivity grid (>= 3 factors, 3 levels where the factor is numeric):
# ``fluids-bench sweep --env ID`` without ``--values`` sweeps this. The nominal value (the
# registered default) is among the levels, so the grid holds the training configuration.
# The FLUIDS-Sensitivity ids sweep the source's six parameters (DEFAULT_VALUES above).
SENSITIVITY: dict[str, dict[str, tuple[Any, ...]]] = {
    "FLUIDS-v0": {
        "layout": ("four_way", "t_junction", "roundabout"),
        "light_cycle_scale": (0.5, 1.0, 2.0),
        "pedestrian_speed": (0.7, 1.4, 2.8),
    },
    "FLUIDS-v1": {
        "lanes": (1, 2),
        "light_cycle_scale": (0.5, 1.0, 2.0),
        "pedestrian_speed": (0.7, 1.4, 2.8),
    },
    "GridWorld-v0": {
        "size": (10, 15, 20),
        "slip_probability": (0.0, 0.16, 0.32),
        "penalty_fraction": (0.04, 0.08, 0.16),
    },
    "DAG-v0": {"mu": (0.1, 0.25, 0.4)},
    "Singulation-v0": {
        "mass_ratio": (1.0, 4.0, 16.0),
        "friction_scale": (0.5, 1.0, 2.0),
        "cluster_std": (0.0, 0.0447, 0.09),
        "object_size_scale": (0.75, 1.0, 1.25),
    },
    "GraspingInClutter-v0": {
        "obstacles": (1, 3, 5),
        "obstacle_size_scale": (0.75, 1.0, 1.25),
        "friction": (0.25, 0.5, 1.0),
        "target_std_frac": (0.0, 0.03, 0.06),
    },
    "DrivingTrack-v0": {
        "edges": (3, 5, 7),
        "half_width": (10.0, 15.0, 20.0),
        "speed": (7.5, 10.0, 12.5),
        "obs_noise": (0.0, 0.05, 0.1),
    },
}
SENSITIVITY["DrivingTrack-Source-v0"] = SENSITIVITY["DrivingTrack-v0"]
# the RL-ready versions sweep what their IL versions sweep (same scenes, other units)
SENSITIVITY["FLUIDS-v2"] = SENSITIVITY["FLUIDS-v3"] = SENSITIVITY["FLUIDS-v4"] = SENSITIVITY[
    "FLUIDS-v1"
]
SENSITIVITY["GraspingInClutter-v1"] = SENSITIVITY["GraspingInClutter-v0"]
# three of the source's six factors as keyword arguments (the legacy Fig. 7.6 runner is v0/v1's)
SENSITIVITY["FLUIDS-Sensitivity-v2"] = {
    "num_cars": (2, 3, 4),
    "num_pedestrians": (0, 2, 4),
    "lidar_noise": (0.0, 0.5, 1.0),
}
SENSITIVITY["FLUIDS-Sensitivity-v3"] = SENSITIVITY["FLUIDS-Sensitivity-v2"]
SENSITIVITY["FLUIDS-Sensitivity-v4"] = SENSITIVITY["FLUIDS-Sensitivity-v2"]
for _task in ("Hopper", "Walker2d", "HalfCheetah", "Humanoid"):
    SENSITIVITY[f"{_task}-IL-v0"] = {
        "body_mass_scale": (0.75, 1.0, 1.25),
        "friction_scale": (0.5, 1.0, 2.0),
        "actuator_gain_scale": (0.75, 1.0, 1.25),
        "obs_noise": (0.0, 0.01, 0.05),
    }


def default_grid(env_id: str) -> Grid | KwargGrid:
    """The default sensitivity grid of `env_id` (ValueError if it has none)."""
    if env_id in LEGACY_IDS:
        return Grid.default()
    if env_id not in SENSITIVITY:
        fail(
            "sweep",
            "env",
            env_id,
            f"an id with a default grid {sorted([*LEGACY_IDS, *SENSITIVITY])}, "
            "or give the grid with --values NAME=V1,V2",
        )
    return KwargGrid(SENSITIVITY[env_id])


LEGACY_IDS = ("FLUIDS-Sensitivity-v0", "FLUIDS-Sensitivity-v1")


def make_grid(env_id: str, overrides: Sequence[tuple[str, Sequence[Any]]]) -> Grid | KwargGrid:
    """The grid `fluids-bench sweep` runs. FLUIDS-Sensitivity ids: the source's six
    parameters with `overrides` replacing some (as before), unless a name outside the six is
    given: then, as for every other id, `overrides` are the whole grid (in the order given),
    and no overrides mean the id's default grid (`SENSITIVITY`). A name given twice
    is refused (it kept its last values silently)."""
    names = [name for name, _ in overrides]
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise ValueError(f"--values gives {twice} more than once; allowed: each name once")
    if env_id in LEGACY_IDS and all(name in PARAMETERS for name in names):
        return Grid.with_overrides(dict(overrides))
    if not overrides:
        return default_grid(env_id)
    return KwargGrid(dict(overrides))
