"""scripts/baselines/rl_baselines.py: schedules over the whole run, resuming, stated departures
from SB3's defaults, and the shared evaluation of the fixed policies (tiny runs on DAG-v0)."""

from __future__ import annotations

import json
import sys

import pytest
from script_module import load_script
from tqdm import tqdm
from train_extra import require_sb3


@pytest.fixture(scope="module")
def rl():
    return load_script("baselines/rl_baselines.py")


def _train(rl, work, steps, algo_kwargs=None):
    with tqdm(disable=True) as bar:
        return rl.train_run("dqn", "DAG-v0", {}, 0, steps, 320, 2, 2, work, bar, algo_kwargs)


@pytest.mark.train_extra
def test_one_learn_call_spans_the_run_and_a_resumed_run_continues_it(rl, tmp_path):
    require_sb3()
    model, curve = _train(rl, tmp_path, 600, {"dqn": {"buffer_size": 1000}})
    assert model._total_timesteps == 600  # DQN's exploration schedule runs over all 600 steps
    # points between rollouts (DQN: 4 steps of 2 envs) once 320 steps have passed, and at the end
    assert [p["steps"] for p in curve] == [320, 600]
    assert model.replay_buffer.buffer_size * 2 == 1000  # the stated kwargs reach the model
    resumed, curve = _train(rl, tmp_path, 1200, {"dqn": {"buffer_size": 1000}})
    assert resumed._total_timesteps == 1200 and resumed.num_timesteps == 1200
    assert [p["steps"] for p in curve] == [320, 600, 920, 1200]
    assert curve[2]["train_cpu_s"] >= curve[1]["train_cpu_s"]


def _main(rl, tmp_path, steps, *extra):
    rl.main([
        "--env", "DAG-v0", "--algos", "dqn", "--seeds", "0", "--steps", str(steps),
        "--eval-every", str(steps), "--eval-episodes", "2", "--final-episodes", "4",
        "--work", str(tmp_path / "work"), "--out", str(tmp_path / "out.json"), *extra,
    ])  # fmt: skip
    return json.loads((tmp_path / "out.json").read_text())


@pytest.mark.train_extra
def test_fixed_policies_are_evaluated_once_per_work_folder(rl, tmp_path):
    require_sb3()
    first = _main(rl, tmp_path, 200)
    (cached,) = (tmp_path / "work").glob("DAG-v0/*/random_4_episodes.json")
    stored = json.loads(cached.read_text())
    assert stored == first["random"]
    cached.write_text(json.dumps({**stored, "mean_return": -99.0}))
    assert _main(rl, tmp_path, 200)["random"]["mean_return"] == -99.0  # read back, not rerun


@pytest.mark.train_extra
def test_a_finished_shorter_run_is_refused_not_reused(rl, tmp_path):
    require_sb3()
    _main(rl, tmp_path, 200)
    with pytest.raises(ValueError, match="finished run of 200 steps"):
        _main(rl, tmp_path, 400)


def _without_the_train_extra(monkeypatch):
    # a None entry in sys.modules makes `import torch` raise ImportError, as on a fresh install
    for name in ("torch", "stable_baselines3"):
        monkeypatch.setitem(sys.modules, name, None)


@pytest.mark.parametrize("text", ["[1]", '{"a2c": {}}', '{"dqn": 3}', "{nope"])
def test_algo_kwargs_must_map_an_algorithm_to_keyword_arguments(rl, tmp_path, text, monkeypatch):
    _without_the_train_extra(monkeypatch)  # arguments are checked before torch is imported
    with pytest.raises(ValueError, match="--algo-kwargs must"):
        _main(rl, tmp_path, 200, "--algo-kwargs", text)


def test_training_without_the_train_extra_names_it(rl, tmp_path, monkeypatch):
    _without_the_train_extra(monkeypatch)
    with pytest.raises(ModuleNotFoundError, match=r"train extra \(torch, stable-baselines3\)"):
        _main(rl, tmp_path, 200)


@pytest.mark.train_extra
def test_references_only_re_evaluates_the_fixed_policies_and_keeps_the_runs(rl, tmp_path):
    require_sb3()
    first = _main(rl, tmp_path, 200)
    stale = {**first, "supervisor": {**first["supervisor"], "mean_return": -99.0}}
    (tmp_path / "out.json").write_text(json.dumps(stale))
    rl.main(["--references-only", "--out", str(tmp_path / "out.json")])
    refreshed = json.loads((tmp_path / "out.json").read_text())
    assert refreshed["supervisor"] == first["supervisor"]
    assert refreshed["runs"] == first["runs"] and refreshed["summary"] == first["summary"]
    assert "--references-only" in refreshed["references_from"]


def test_a_supervisor_row_is_cached_per_teacher_weights(rl, tmp_path):
    """A new shipped teacher is evaluated afresh, not read back from its predecessor's file."""
    from fluids_bench.tasks.locomotion.supervisors import manifest

    def act(obs, env):
        return env.unwrapped.supervisor_action()

    kwargs = {"max_episode_steps": 5}
    rl._cached_eval(tmp_path, "supervisor", "Hopper-IL-v0", kwargs, act, 1)
    (cached,) = tmp_path.glob("supervisor_1_episodes_*.json")
    assert cached.name.endswith(manifest()["Hopper"]["sha256"][:12] + ".json")
