"""``fluids-bench sweep --env ID`` over any registered id's keyword arguments: the kwarg grid,
the per-task default grids, the store's columns, resuming, workers and backends, refusals."""

from __future__ import annotations

import json

import pytest

from fluids_bench.cli import main
from fluids_bench.core.parallel import import_ray
from fluids_bench.sweep.grid import SENSITIVITY, Grid, KwargGrid, make_grid, parse_values
from fluids_bench.sweep.plot import pair_table, summary
from fluids_bench.sweep.run import probe_env
from fluids_bench.sweep.store import RESULTS, Layout, ResultStore, load_rows

GRIDWORLD = [
    *("--env", "GridWorld-v0", "--policy", "supervisor", "--episodes", "2", "--no-progress"),
    *("--values", "size=8,10", "--values", "slip_probability=0,0.2,0.4"),
]


def test_kwarg_grid_order_kinds_and_normalisation():
    grid = KwargGrid({"layout": ["four_way", "roundabout"], "num_cars": [1, 3], "x": [0.5, 1]})
    assert grid.names == ("layout", "num_cars", "x")
    assert grid.kinds == {"layout": "str", "num_cars": "int", "x": "float"}
    assert len(grid) == 8 and grid.configuration(7) == {
        "layout": "roundabout",
        "num_cars": 3,
        "x": 1.0,
    }
    assert grid.normalise("layout", "roundabout") == 1.0 and grid.normalise("x", 0.75) == 0.5
    for bad in ({"a": [2, 1]}, {"a": [1, "b"]}, {"a": []}, {"a": ["x,y"]}, {"a": [1, 1]}):
        with pytest.raises(ValueError, match="KwargGrid"):
            KwargGrid(bad)


def test_make_grid_keeps_the_source_grid_for_its_ids_and_defaults_elsewhere():
    assert make_grid("FLUIDS-Sensitivity-v0", [("cars", [2])]) == Grid.with_overrides({"cars": [2]})
    assert make_grid("FLUIDS-Sensitivity-v1", [("lanes", [1, 2])]).names == ("lanes",)
    assert make_grid("Singulation-v0", []).names == tuple(SENSITIVITY["Singulation-v0"])
    assert make_grid("Singulation-v0", [parse_values("mass_ratio=1,2")]).names == ("mass_ratio",)
    with pytest.raises(ValueError, match=r"--values gives \['size'\] more than once"):
        make_grid("GridWorld-v0", [("size", [5]), ("size", [6])])  # the last one won, silently
    with pytest.raises(ValueError, match="--values"):
        make_grid("CartPole-v1", [])


def test_every_registered_id_has_a_default_grid():
    """``fluids-bench sweep --env ID`` with no ``--values`` works for every Gymnasium id."""
    from fluids_bench.registration import ENV_SPECS
    from fluids_bench.sweep.grid import LEGACY_IDS

    assert sorted(set(ENV_SPECS) - set(SENSITIVITY) - set(LEGACY_IDS)) == []


@pytest.mark.parametrize("env_id", sorted(SENSITIVITY))
def test_every_default_grid_passes_its_envs_own_checks(env_id):
    grid = make_grid(env_id, [])
    if env_id != "DAG-v0":  # DAG has one knob (mu)
        assert len(grid.names) >= 3
    probe_env(grid, env_id)


def test_the_env_refuses_a_bad_value_before_any_work(tmp_path, capsys):
    out = tmp_path / "bad"
    args = ["sweep", "--out", str(out), *GRIDWORLD]
    assert main([*args, "--values", "slip_probability=0,2"]) == 2
    assert "slip_probability" in capsys.readouterr().err and not out.exists()
    assert main([*args[:-4], "--values", "sise=3,4"]) == 2
    assert "unknown argument" in capsys.readouterr().err and not out.exists()


def test_rows_resume_and_agree_across_workers_and_backends(tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    assert main(["sweep", "--out", str(one), "--workers", "1", *GRIDWORLD]) == 0
    rows = load_rows(one)
    assert len(rows) == 6 and {"mean_return", "std_return", "truncations"} <= set(rows[0])
    assert main(["sweep", "--out", str(two), "--workers", "2", *GRIDWORLD]) == 0
    assert load_rows(two) == rows
    # kill-like damage: the last row half-written; the rerun redoes only that one
    path = one / RESULTS
    data = path.read_bytes()
    path.write_bytes(data[: data.rfind(b"\n", 0, len(data) - 1) + 5])
    assert main(["sweep", "--out", str(one), "--workers", "1", *GRIDWORLD]) == 0
    assert load_rows(one) == rows
    assert (one / "heatmaps.png").stat().st_size > 1000
    table = json.loads((one / "summary.json").read_text())
    assert table["metric"] == "return" and set(table["factors"]) == {"size", "slip_probability"}
    try:
        import_ray()
    except ImportError:
        return
    ray_out = tmp_path / "ray"
    args = ["sweep", "--out", str(ray_out), "--backend", "ray", "--workers", "2", *GRIDWORLD]
    assert main(args) == 0
    assert load_rows(ray_out) == rows


def test_a_folder_of_another_sweep_is_refused_before_any_work(tmp_path, capsys):
    out = tmp_path / "s"
    assert main(["sweep", "--out", str(out), *GRIDWORLD]) == 0
    before = (out / RESULTS).read_bytes()
    args = ["sweep", "--out", str(out), "--env", "DAG-v0", "--policy", "supervisor"]
    assert main([*args, "--no-progress"]) == 2
    assert "other settings" in capsys.readouterr().err
    # a trained policy: refused before training
    assert main(["sweep", "--out", str(out), "--env", "DAG-v0", "--demos", "1"]) == 2
    assert "other settings" in capsys.readouterr().err
    assert (out / RESULTS).read_bytes() == before and not (out / "policy.pkl").exists()


def test_a_trained_learner_with_a_separate_training_configuration(tmp_path):
    out = tmp_path / "bc"
    args = ["sweep", "--out", str(out), "--env", "GridWorld-v0", "--demos", "2"]
    args += ["--train-kwarg", "slip_probability=0", "--values", "slip_probability=0,0.3"]
    args += ["--episodes", "2", "--no-progress", "--algo", "dagger", "--iterations", "2"]
    assert main(args) == 0
    info = json.loads((out / "policy.json").read_text())
    assert info["settings"]["algo"] == "dagger"
    assert info["settings"]["config"]["env_kwargs"] == {"slip_probability": 0}
    assert len(load_rows(out)) == 2
    manifest = ResultStore(out).read_manifest()
    assert manifest["format"] == 2 and manifest["grid"] == {"slip_probability": [0, 0.3]}


def test_store_layout_round_trips_strings_and_summaries(tmp_path):
    grid = KwargGrid({"layout": ["four_way", "roundabout"], "lights": [False, True]})
    layout = Layout.of(grid)
    rows = []
    with ResultStore(tmp_path, layout) as store:
        store.open({"format": 2, "grid": grid.to_dict(), "kinds": grid.kinds})
        for index, config in grid.configurations():
            row = {"index": index, **config, "episodes": 2, "successes": index % 3}
            row |= {"terminations": 2, "truncations": 0, "success_rate": (index % 3) / 2}
            row |= {"mean_return": 0.5 * index, "std_return": 0.1, "mean_steps": 10.0}
            store.append(row)
        rows = store.sorted_rows()
    assert load_rows(tmp_path) == rows and rows[3]["layout"] == "roundabout"
    assert pair_table(rows, grid, "layout", "lights", "success") == [[0.0, 0.5], [1.0, 0.0]]
    data = summary(rows, grid, "success")
    assert [e["episodes"] for e in data["factors"]["layout"]] == [4, 4]


def test_train_on_grid_test_on_grid_matrix(tmp_path, capsys):
    out = tmp_path / "m"
    args = ["sweep", "--out", str(out), "--env", "GridWorld-v0", "--demos", "2"]
    args += ["--values", "slip_probability=0,0.3", "--train-values", "slip_probability=0,0.3"]
    args += ["--episodes", "2", "--no-progress", "--workers", "1"]
    assert main(args) == 0
    matrix = json.loads((out / "matrix.json").read_text())
    trained = [e["train"] for e in matrix["entries"]]
    assert trained == [{"slip_probability": 0}, {"slip_probability": 0.3}]
    for k, entry in enumerate(matrix["entries"]):
        info = json.loads((out / f"train_{k}" / "policy.json").read_text())
        assert info["settings"]["config"]["env_kwargs"] == entry["train"]
        assert len(load_rows(out / f"train_{k}")) == 2
    assert "trained on" in (out / "matrix.md").read_text()
    assert main(args) == 0  # resumes: nothing retrained, nothing rerun
    assert "resuming: 2 of 2" in capsys.readouterr().out
    # a plain sweep is not written into a matrix folder, nor the supervisor into a matrix
    assert main(["sweep", "--out", str(out), *GRIDWORLD]) == 2
    assert main([*args, "--policy", "supervisor"]) == 2


def test_an_id_without_a_success_flag_reports_no_success_rate(tmp_path, capsys):
    args = ["--env", "GridWorld-v0", "--policy", "supervisor", "--episodes", "1", "--no-progress"]
    args += ["--values", "size=8", "--values", "slip_probability=0"]
    assert main(["sweep", "--out", str(tmp_path / "s"), "--workers", "1", *args]) == 0
    out = capsys.readouterr().out
    assert "mean return" in out and "success rate" not in out
