"""The Fig. 7.6 plot: marginal success rates against normalised parameters, written as PNG."""

from __future__ import annotations

import pytest

from fluids_bench.sweep.grid import ORDER, Grid
from fluids_bench.sweep.plot import marginals, plot_sensitivity, reports_success


def _rows(grid: Grid) -> list[dict]:
    # succeed in every episode with 2 cars, never with 3
    return [
        {"index": i, **c, "episodes": 4, "successes": 4 if c["cars"] == 2 else 0}
        for i, c in grid.configurations()
    ]


def test_marginals_average_over_the_other_parameters():
    grid = Grid.with_overrides({"cars": [2, 3], "pedestrians": [0, 4], "lidar_dropout": [0]})
    points = marginals(_rows(grid), grid)
    assert set(points) == set(ORDER)
    assert points["cars"] == [(0.0, 1.0), (1.0, 0.0)]
    assert points["pedestrians"] == [(0.0, 0.5), (1.0, 0.5)]
    assert points["lidar_dropout"] == [(0.0, 0.5)]
    # a partial sweep plots what has finished
    partial = marginals(_rows(grid)[:1], grid)
    assert partial["cars"] == [(0.0, 1.0)]


def test_plot_is_a_small_png(tmp_path):
    grid = Grid.default()
    path = tmp_path / "sweep.png"
    plot_sensitivity(_rows(grid), grid, path)
    data = path.read_bytes()
    assert data.startswith(b"\x89PNG") and len(data) < 200_000
    plot_sensitivity([], grid, path)  # nothing finished yet: empty axes, no error
    assert path.read_bytes().startswith(b"\x89PNG")


@pytest.mark.parametrize("value", [2, 2.0])
def test_values_match_by_number(value):
    grid = Grid.with_overrides({"cars": [2]})
    rows = [{"index": 0, **grid.configuration(0), "episodes": 1, "successes": 1}]
    rows[0]["cars"] = value
    assert marginals(rows, grid)["cars"] == [(0.0, 1.0)]


@pytest.mark.parametrize(
    "env_id, expected",
    [
        ("FLUIDS-Sensitivity-v1", True),  # is_success only on the terminating step
        ("FLUIDS-v0", True),
        ("Singulation-v0", True),
        ("GridWorld-v0", False),
    ],
)
def test_the_metric_is_success_where_the_env_reports_it(env_id, expected):
    assert reports_success(env_id) is expected
