"""The attack of issue #44 on keyword arguments, actions and the command line, as tests: every
case is refused with a `ValueError` (CLI: exit 2, one line) naming the user's argument, or works;
never a raw error, never a silent acceptance.

The cases are generated from the registry and from argparse, so a new id, kwarg or option is
attacked by being added. Every run takes a sample (the unmarked cases); the rest are marked `fuzz_full` and skip, with that
reason, unless `FLUIDS_BENCH_FULL_FUZZ=1` (a few minutes on 2 cores):

    FLUIDS_BENCH_FULL_FUZZ=1 python3 -m pytest -q -n 2 tests/test_fuzz.py \
        tests/core/test_snapshot_fuzz.py tests/tasks/fluids/sim/test_layouts.py
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.envs.registration import load_env_creator

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench import cli
from fluids_bench.algos.registry import ALGORITHMS
from fluids_bench.commands.train import ALGO_OPTIONS
from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS, make_parallel_env
from fluids_bench.tasks.fluids.multi_agent import FluidsParallelEnv

# -- keyword arguments -----------------------------------------------------------------------

# huge ints (10**400 overflowed float()), huge and non-finite floats, and None
BAD_NUMBERS = (10**400, 1e308, None, -(10**400), -1e308, 10**30, -1e300, math.nan, math.inf)
SEED_KWARGS = {"world_seed"}  # any non-negative integer seeds numpy: accepted on purpose


def _constructor(env_id: str):
    if env_id in PARALLEL_ENV_SPECS:
        return FluidsParallelEnv
    return load_env_creator(gym.spec(env_id).entry_point)


def numeric_kwargs(env_id: str) -> list[str]:
    """The keyword arguments of an id's env whose default is a number (not a bool)."""
    params = inspect.signature(_constructor(env_id)).parameters.values()
    return [
        p.name
        for p in params
        if isinstance(p.default, int | float) and not isinstance(p.default, bool)
    ]


def _make(env_id: str, **kwargs):
    if env_id in PARALLEL_ENV_SPECS:
        return make_parallel_env(env_id, **kwargs)
    return gym.make(env_id, **kwargs)


def _kwarg_cases() -> list:
    """Every (id, kwarg, bad value); the sample gives each kwarg of each id one value, in turn
    (the first kwarg of every id gets 10**400, the issue's case)."""
    cases = []
    for env_id in [*ENV_SPECS, *PARALLEL_ENV_SPECS]:
        for i, name in enumerate(numeric_kwargs(env_id)):
            for j, value in enumerate(BAD_NUMBERS):
                sample = j == i % len(BAD_NUMBERS)
                marks = () if sample else (pytest.mark.fuzz_full,)
                cases.append(pytest.param(env_id, name, value, marks=marks))
    return cases


@pytest.mark.parametrize(("env_id", "name", "value"), _kwarg_cases())
def test_a_huge_or_non_finite_kwarg_is_refused_naming_it(env_id, name, value):
    try:
        env = _make(env_id, **{name: value})
    except ValueError as exc:
        assert f"'{name}'" in str(exc), str(exc)
        return
    env.close()
    accepted = name in SEED_KWARGS and isinstance(value, int) and value >= 0
    assert accepted, f"{env_id}: {name}={value!r} was accepted silently"


def test_every_id_has_numeric_kwargs_to_attack():
    # the generator must see through reject_unknown_kwargs to the real signature
    for env_id in [*ENV_SPECS, *PARALLEL_ENV_SPECS]:
        assert numeric_kwargs(env_id), env_id


@pytest.mark.parametrize("env_id", sorted(PARALLEL_ENV_SPECS))
def test_controlled_cars_none_is_refused_on_multi_agent_ids(env_id):
    # None means "the single-agent env's ego" inside the scenario; it was a raw TypeError here
    with pytest.raises(ValueError, match="field 'controlled_cars' is None"):
        make_parallel_env(env_id, controlled_cars=None)


# -- actions ---------------------------------------------------------------------------------

HUGE_ACTIONS = (1e155, -1e155, 1e300, -np.finfo(np.float64).max)


def _action_cases() -> list:
    cases = []
    for k, env_id in enumerate(ENV_SPECS):
        for j, value in enumerate(HUGE_ACTIONS):
            marks = () if j == k % len(HUGE_ACTIONS) else (pytest.mark.fuzz_full,)
            cases.append(pytest.param(env_id, value, marks=marks))
    return cases


@pytest.mark.parametrize(("env_id", "value"), _action_cases())
def test_a_huge_finite_action_steps_to_finite_numbers(env_id, value):
    """Finite actions outside the box are clipped (each env card says how); the step's reward
    and observation stay finite (Hopper-IL-v0 gave a reward of -inf for 1e155) and the label
    stays in the space."""
    env = gym.make(env_id)
    space = env.action_space
    if not isinstance(space, gym.spaces.Box):
        pytest.skip("a Discrete space: out-of-range integers are refused (test_registry)")
    env.reset(seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # an overflow on the way is a failure
        obs, reward, _, _, info = env.step(np.full(space.shape, value))
    assert math.isfinite(reward), reward
    assert np.isfinite(np.asarray(obs, dtype=float)).all()
    assert space.contains(info["supervisor_action"])
    env.close()


# -- the command line ------------------------------------------------------------------------

# a cheap valid command per subcommand: a bad value that slipped through would run this
BASE = {
    "collect": ["collect", "--env", "DAG-v0", "--episodes", "1", "--dataset", "fuzz/x-v0"],
    "train": ["train", "--env", "DAG-v0", "--iterations", "1", "--eval-episodes", "1"],
    "sweep": ["sweep", "--env", "DAG-v0", "--values", "mu=0.1", "--policy", "supervisor"],
}
BAD_INTS = ("-1", "-" + "9" * 400)
BAD_FLOATS = ("nan", "inf", "-inf", "1e400")


def _subparser(command: str):
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sub.choices[command]


def _numeric_options(command: str) -> list[tuple[str, type, bool]]:
    """(option, type, takes a list) of every int or float option of ``command``."""
    out = []
    for action in _subparser(command)._actions:
        if action.type in (int, float) and action.option_strings:
            out.append((action.option_strings[0], action.type, action.nargs in ("+", "*")))
    return out


def _algo_for(option: str) -> str:
    """An algorithm that takes ``option`` (train's algorithm options apply to some only)."""
    if option not in ALGO_OPTIONS:
        return "bc"
    field = ALGO_OPTIONS[option][0]
    return next(
        name
        for name, algo in ALGORITHMS.items()
        if field in {f.name for f in dataclasses.fields(algo.config_class)}
    )


def _cli_cases() -> list:
    cases = []
    for command in BASE:
        for i, (option, kind, _) in enumerate(_numeric_options(command)):
            values = BAD_INTS if kind is int else BAD_FLOATS
            for j, value in enumerate(values):
                marks = () if j == i % len(values) else (pytest.mark.fuzz_full,)
                cases.append(pytest.param(command, option, value, marks=marks))
    return cases


# the issue's cases (all in the CI sample): (arguments, what the one line must say)
ISSUE_CASES = [
    (["collect", "--env", "Nope-v0"], "--env is 'Nope-v0', not a registered id"),
    (["collect", "--env", "FLUIDS-MultiAgent-v1"], "--env is 'FLUIDS-MultiAgent-v1', a multi-"),
    (["collect", "--env", "CartPole-v1"], "--env is 'CartPole-v1', an env with no supervisor"),
    (["collect", "--env", "DAG-v0", "--noise", "-1"], "--noise is -1.0; allowed: a finite"),
    (
        ["collect", "--env", "DAG-v0", "--ref-min-score", "nan", "--ref-max-score", "1"],
        "--ref-min-score is nan; allowed: a finite number",
    ),
    (
        ["collect", "--env", "DAG-v0", "--ref-min-score", "5", "--ref-max-score", "1"],
        "--ref-min-score is 5.0 and --ref-max-score is 1.0; allowed: a minimum below",
    ),
    (
        ["collect", "--env", "DAG-v0", "--env-kwarg", "mu=0.1", "--env-kwarg", "mu=0.2"],
        "--env-kwarg gives 'mu' twice",
    ),
    (  # episode i is seeded --seed + i: the last seed would not fit 32 bits
        ["collect", "--env", "DAG-v0", "--seed", "4294967295", "--episodes", "2"],
        "--episodes is 2; allowed: an integer in [1, 1]",
    ),
    (
        ["sweep", "--env", "CartPole-v1", "--values", "sutton_barto_reward=true"],
        "--env is 'CartPole-v1', an env with no supervisor",
    ),
    (["sweep", "--policy", "/etc/hostname"], "--policy is '/etc/hostname', not a readable"),
    (["sweep", "--values", "cars=2", "--values", "cars=3"], "--values gives 'cars' twice"),
    (["sweep", "--workers", "0"], "--workers is 0; allowed: an integer in [1, "),
    # a process per episode: bounded by the cores (4 each), or by 10,000 on a Ray cluster
    (["collect", "--env", "DAG-v0", "--workers", "100000"], "--workers is 100000; allowed: an"),
    (["sweep", "--workers", "100000"], "--workers is 100000; allowed: an integer in [1, "),
    (
        ["train", "--env", "DAG-v0", "--algo", "bc", "--workers", "100000"],
        "--workers is 100000; allowed: an integer in [1, ",
    ),
    (
        ["train", "--env", "GridWorld-v0", "--algo", "bc", "--iterations", "10", "--eval-at", "99"],
        "--eval-at is (99,); allowed: a tuple of iteration numbers in [0, 10]",
    ),
    (["train", "--env", "FLUIDS-MultiAgent-v0", "--algo", "bc"], "--env is 'FLUIDS-MultiAgent"),
]


def _run_cli(args, tmp_path, monkeypatch, capsys) -> tuple[int, list[str]]:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    try:
        out = ["--out", "o"] if args[0] in ("sweep", "train") else []
        code = cli.main([*args, "--no-progress", *out])
    except SystemExit as exc:  # argparse's own refusal (usage line + one error line)
        code = exc.code
    err = capsys.readouterr().err.strip().splitlines()
    return code, err


@pytest.mark.parametrize(("args", "message"), ISSUE_CASES)
def test_the_issues_cli_cases_end_in_one_line_naming_the_option(
    args, message, tmp_path, monkeypatch, capsys
):
    if args[0] == "collect":
        args = [*args, "--dataset", "fuzz/x-v0"]
        args += [] if "--episodes" in args else ["--episodes", "1"]
    code, err = _run_cli(args, tmp_path, monkeypatch, capsys)
    assert code == 2, err
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "o").exists() and not (tmp_path / "minari" / "fuzz").exists()


@pytest.mark.parametrize(("command", "option", "value"), _cli_cases())
def test_a_bad_number_for_any_option_is_refused_naming_it(
    command, option, value, tmp_path, monkeypatch, capsys
):
    args = [*BASE[command], option, value]
    if command == "train":
        args += ["--algo", _algo_for(option)]
    code, err = _run_cli(args, tmp_path, monkeypatch, capsys)
    assert code == 2, (args, err)
    assert err and option in err[-1], (args, err)
    assert "Traceback" not in "\n".join(err)
