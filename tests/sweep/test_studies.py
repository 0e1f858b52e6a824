"""The sensitivity studies' settings (scripts/reproductions/sensitivity_study.py): every grid
passes its env's own checks, holds the nominal configuration the learners are trained on (the
return tables and figures divide by the supervisor's return there), and has three factors at
three levels."""

from __future__ import annotations

import pytest
from script_module import load_script

from fluids_bench.sweep.grid import KwargGrid
from fluids_bench.sweep.run import probe_env

study = load_script("reproductions/sensitivity_study.py")

# factors whose nominal value no level equals, in studies whose rows are kept as they are
OFF_GRID_NOMINAL = {
    ("singulation", "cluster_std"),  # level 0.0447 m; nominal sqrt(0.002) = 0.04472 m
    ("track", "edges"),  # nominal None: the edge count is drawn per episode
}


@pytest.mark.parametrize("task", sorted(study.STUDIES))
def test_each_study_grid_is_valid_and_holds_its_nominal_configuration(task):
    env_id, fixed, values, demos, *limit = study.STUDIES[task]
    grid = KwargGrid(values)
    probe_env(grid, env_id, fixed)
    nominal = study.nominal_configuration(env_id, grid.names, fixed)
    for name, value in nominal.items():
        if (task, name) not in OFF_GRID_NOMINAL:
            assert value in grid.values[name], (task, name, value)
    assert demos >= 4 and task in study.EXPECTED_MINUTES
    if task != "singulation_size":  # the one single-factor study
        assert grid.shape == (3, 3, 3)


def test_nominal_configuration_reads_the_registration_then_the_env_defaults():
    # FLUIDS-Sensitivity-v1 registers num_cars=3; car_mass is the env's own default
    nominal = study.nominal_configuration(
        "FLUIDS-Sensitivity-v1", ("num_cars", "car_mass", "lidar_noise"), {"lidar_noise": 0.5}
    )
    assert nominal == {"num_cars": 3, "car_mass": 1500.0, "lidar_noise": 0.5}
