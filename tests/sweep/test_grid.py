"""The sweep's parameter grid: the default 256 configurations, numbering, env keywords, errors."""

from __future__ import annotations

import gymnasium as gym
import pytest

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.sweep.grid import (
    DEFAULT_VALUES,
    ORDER,
    Grid,
    env_kwargs,
    parse_values,
    source_mass_to_kg,
)


def test_default_grid_is_the_sources_256_configurations():
    grid = Grid.default()
    assert len(grid) == 256 and grid.shape == (4, 4, 2, 2, 2, 2)
    assert grid.values["cars"] == (2, 3, 4, 5)
    assert grid.values["pedestrians"] == (0, 1, 3, 4)
    assert grid.values["lights"] == (False, True)
    configurations = [c for _, c in grid.configurations()]
    assert len({tuple(c.values()) for c in configurations}) == 256  # all distinct
    assert configurations[0] == {name: values[0] for name, values in DEFAULT_VALUES.items()}
    assert configurations[-1] == {name: values[-1] for name, values in DEFAULT_VALUES.items()}
    # row-major: the last parameter varies fastest
    assert configurations[1]["car_mass"] == 3000.0 and configurations[1]["cars"] == 2
    assert configurations[64]["cars"] == 3


def test_mass_mapping_spans_half_to_twice_the_nominal_mass():
    assert source_mass_to_kg(0) == 750.0 and source_mass_to_kg(200) == 3000.0
    assert source_mass_to_kg(200 / 3) == pytest.approx(1500.0)
    assert Grid.default().values["car_mass"] == (source_mass_to_kg(0), source_mass_to_kg(200))


def test_env_kwargs_count_the_ego_among_the_cars():
    configuration = Grid.default().configuration(255)
    kwargs = env_kwargs(configuration)
    assert kwargs == {
        "num_cars": 4,
        "num_pedestrians": 4,
        "lidar_noise": 1.0,
        "lidar_dropout": 1.0,
        "lights": True,
        "car_mass": 3000.0,
    }
    env = gym.make("FLUIDS-Sensitivity-v0", **kwargs)
    env.reset(seed=0)
    assert int(env.unwrapped.world.is_car.sum()) == 5
    env.close()


def test_normalise_maps_each_range_to_unit_interval():
    grid = Grid.default()
    assert grid.normalise("cars", 2) == 0.0 and grid.normalise("cars", 5) == 1.0
    assert grid.normalise("pedestrians", 1) == 0.25
    assert grid.normalise("car_mass", 3000.0) == 1.0
    assert Grid.with_overrides({"cars": [3]}).normalise("cars", 3) == 0.0


@pytest.mark.parametrize(
    "values, match",
    [
        ({"cars": [2, 2]}, "increasing"),
        ({"cars": [3, 2]}, "increasing"),
        ({"cars": []}, "non-empty"),
        ({"cars": "2,3"}, "non-empty"),
        ({"cars": [2.5]}, "integer"),
        ({"cars": [0]}, r"field 'cars' is 0; allowed: a value in \[1, 64\]"),
        ({"pedestrians": [-1]}, "pedestrians"),
        ({"lidar_dropout": [0.5, 1.5]}, "lidar_dropout"),
        ({"lidar_noise": [float("nan")]}, "finite"),
        ({"lights": [2]}, "lights"),
        ({"car_mass": [True]}, "car_mass"),
        ({"speed": [1]}, "parameter names"),
    ],
)
def test_invalid_values_name_the_field(values, match):
    with pytest.raises(ValueError, match=match):
        Grid.with_overrides(values)


def test_missing_parameters_and_bad_indices_are_refused():
    with pytest.raises(ValueError, match="every parameter"):
        Grid({"cars": [2]})
    with pytest.raises(ValueError, match="index"):
        Grid.default().configuration(256)
    with pytest.raises(ValueError, match="index"):
        Grid.default().configuration(-1)


def test_parse_values():
    assert parse_values("cars=2,5") == ("cars", [2, 5])
    assert parse_values("lidar_noise=0,0.5") == ("lidar_noise", [0, 0.5])
    assert parse_values("lights=off,on") == ("lights", [False, True])
    assert Grid.with_overrides(dict([parse_values("lidar_noise=0,0.5")])).values["lidar_noise"] == (
        0.0,
        0.5,
    )
    # any env keyword argument, strings for names (a layout); the env checks the values
    assert parse_values("speed=1") == ("speed", [1])
    assert parse_values("layout=four_way,roundabout") == ("layout", ["four_way", "roundabout"])
    for bad in ("cars", "cars=two", "9x=1", "layout=a b"):
        with pytest.raises(ValueError, match="--values"):
            parse_values(bad)
    assert set(Grid.default().to_dict()) == set(ORDER)
