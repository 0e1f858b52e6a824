"""A results file records what ran: the command stored in every RL-baseline results file,
parsed by the script that wrote it, gives back the file's recorded configuration (env, kwargs,
seeds, settings), in full and in the short form the docs tests run; where a file names an
equivalent command (written before its id existed), the two build the same env and episodes."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from script_module import load_script

import fluids_bench  # noqa: F401  (registers the ids)

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = "scripts/baselines/rl_baselines.py"
SHORT = {"--steps": "256", "--eval-every": "256", "--eval-episodes": "1", "--final-episodes": "2"}
SHRUNK = {"steps", "eval_every", "eval_episodes", "final_episodes", "eval_seeds"}


def _curve_files() -> list[Path]:
    out = []
    for path in sorted((ROOT / "docs" / "results").glob("*.json")):
        data = json.loads(path.read_text(encoding="utf-8"))
        command = data.get("command", "") if isinstance(data, dict) else ""
        if SCRIPT in command and "--ablation" not in command and "runs" in data:
            out.append(path)
    return out


@pytest.fixture(scope="module")
def rl():
    return load_script("baselines/rl_baselines.py")


def _argv(command: str) -> list[str]:
    words = shlex.split(command)
    return words[words.index(SCRIPT) + 1 :]


def _short(argv: list[str]) -> list[str]:
    out, i = [], 0
    while i < len(argv):
        if argv[i] in SHORT:
            out += [argv[i], SHORT[argv[i]]]
            i += 2
        else:
            out.append(argv[i])
            i += 1
    for option, value in SHORT.items():
        if option not in argv:
            out += [option, value]
    return out


def _recorded(data: dict) -> dict:
    settings = {k: v for k, v in data["settings"].items() if k != "machine"}
    return {"env_id": data["env_id"], "env_kwargs": data["env_kwargs"], "seeds": data["seeds"],
            "settings": settings}  # fmt: skip


def _configuration(rl, argv: list[str], recorded: dict) -> dict:
    got = rl.configuration(rl.build_parser().parse_args(argv))
    got["settings"] = {k: v for k, v in got["settings"].items() if k in recorded["settings"]}
    return got


@pytest.mark.parametrize("path", _curve_files(), ids=lambda p: p.name)
def test_the_recorded_command_gives_the_recorded_configuration(rl, path):
    data = json.loads(path.read_text(encoding="utf-8"))
    recorded = _recorded(data)
    argv = _argv(data["command"])
    assert _configuration(rl, argv, recorded) == recorded
    short = _configuration(rl, _short(argv), recorded)
    for key in ("env_id", "env_kwargs", "seeds"):
        assert short[key] == recorded[key]
    kept = {k: v for k, v in recorded["settings"].items() if k not in SHRUNK}
    assert {k: short["settings"][k] for k in kept} == kept


def test_curve_files_are_found():
    assert len(_curve_files()) >= 10


def _episode(env_id: str, kwargs: dict, steps: int = 40) -> list:
    env = gym.make(env_id, **kwargs)
    obs, info = env.reset(seed=7)
    trace = [obs]
    for _ in range(steps):
        obs, reward, term, trunc, info = env.step(info["supervisor_action"])
        trace += [obs, reward, term]
        if term or trunc:
            break
    return trace


@pytest.mark.parametrize(
    "path", [p for p in _curve_files() if "equivalent_command" in json.loads(p.read_text())],
    ids=lambda p: p.name,
)  # fmt: skip
def test_an_equivalent_command_builds_the_same_env_and_episodes(rl, path):
    data = json.loads(path.read_text(encoding="utf-8"))
    ran = rl.build_parser().parse_args(_argv(data["command"]))
    same = rl.build_parser().parse_args(_argv(data["equivalent_command"]))
    assert ran.env == data["env_id"]  # the file records what ran
    a_kwargs, b_kwargs = json.loads(ran.env_kwargs), json.loads(same.env_kwargs)
    a, b = gym.make(ran.env, **a_kwargs), gym.make(same.env, **b_kwargs)
    assert a.spec.kwargs == b.spec.kwargs and a.spec.max_episode_steps == b.spec.max_episode_steps
    for x, y in zip(_episode(ran.env, a_kwargs), _episode(same.env, b_kwargs), strict=True):
        assert np.array_equal(x, y)
    settings = ("seeds", "steps", "eval_every", "final_episodes", "n_envs", "algos", "algo_kwargs")
    assert all(getattr(ran, k) == getattr(same, k) for k in settings)
