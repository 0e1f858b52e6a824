"""Checks of command-line options shared by the subcommands: every refusal names the `--flag`
the user typed, in the shape `cli.check_seeds` uses (`--workers is 0; allowed: ...`).

Configs deeper down (`RunConfig`, `ActorSpec`, ...) name their fields (`ActorSpec: field
'epsilon' is -1.0; ...`); `options_named` renames those fields to the options that set them.
"""

from __future__ import annotations

import importlib
import math
import os
import re
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import Any

# the suite's standard config error (fluids_bench.core.validation.fail)
_FIELD_ERROR = re.compile(r"^[\w.]+: field '(?P<field>\w+)' is (?P<rest>.*)$", re.S)


@contextmanager
def options_named(options: Mapping[str, str]) -> Iterator[None]:
    """Inside, a config's `"<Where>: field 'x' is ..."` error for a field in `options`
    (field name -> option, e.g. `{"epsilon": "--noise"}`) is raised again as `"--noise is
    ..."`; any other error passes unchanged."""
    try:
        yield
    except ValueError as exc:
        match = _FIELD_ERROR.match(str(exc))
        if match is None or match["field"] not in options:
            raise
        raise ValueError(f"{options[match['field']]} is {match['rest']}") from None


def check_int_option(option: str, value: Any, lo: int, hi: int | None = None) -> int:
    """`value` of `option` must be an integer in `[lo, hi]` (`hi=None`: no upper bound)."""
    if isinstance(value, bool) or not isinstance(value, int) or value < lo:
        _refuse(option, value, lo, hi)
    if hi is not None and value > hi:
        _refuse(option, value, lo, hi)
    return value


def _refuse(option: str, value: Any, lo: int, hi: int | None) -> None:
    raise ValueError(f"{option} is {value}; allowed: an integer in [{lo}, {hi or 'inf'}]")


CLUSTER_WORKERS = 10_000  # Ray tasks in flight on a cluster (--ray-address)


def check_workers_option(workers: Any, backend: str, address: str | None) -> int:
    """`--workers`: at least 1; on this machine (process pool, or a local Ray) at most 4 per
    CPU core, since more only compete for the cores (and `collect --workers 100000` started a
    process per episode); on a Ray cluster at most `CLUSTER_WORKERS`."""
    if backend == "ray" and address is not None:
        return check_int_option("--workers", workers, 1, CLUSTER_WORKERS)
    cores = os.cpu_count() or 1
    try:
        return check_int_option("--workers", workers, 1, 4 * cores)
    except ValueError as exc:
        raise ValueError(f"{exc} (4 per CPU core; {cores} here)") from None


def check_finite_option(option: str, value: float | None) -> float | None:
    """`value` of `option` (None: not given) must be a finite number (argparse's `float`
    accepts `nan` and `inf`)."""
    if value is not None and not math.isfinite(value):
        raise ValueError(f"{option} is {value}; allowed: a finite number")
    return value


def unique_keys(option: str, pairs: Sequence[tuple[str, Any]]) -> dict[str, Any]:
    """The `KEY=VALUE` pairs of a repeatable option as a dict; a KEY given twice is refused
    (argparse would keep the last one silently)."""
    seen: dict[str, Any] = {}
    for key, value in pairs:
        if key in seen:
            raise ValueError(
                f"{option} gives {key!r} twice ({key}={seen[key]!r} and {key}={value!r}); "
                "allowed: each name once"
            )
        seen[key] = value
    return seen


def check_gym_id(option: str, env_id: str) -> str:
    """`env_id` must name a registered Gymnasium id (`module:Id` imports the module first, as
    `gym.make` does); a PettingZoo id of the suite is pointed out as such."""
    import gymnasium as gym

    from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS

    if env_id in PARALLEL_ENV_SPECS:
        raise ValueError(
            f"{option} is {env_id!r}, a multi-agent (PettingZoo) id; allowed: a Gymnasium id, "
            f"{_some(ENV_SPECS)}"
        )
    module, _, name = env_id.rpartition(":")
    try:
        if module:  # "fluids_bench:FLUIDS-v1", as gym.make reads it
            importlib.import_module(module)
        gym.spec(name)
    except (gym.error.Error, ImportError) as exc:  # NameNotFound, VersionNotFound...
        raise ValueError(
            f"{option} is {env_id!r}, not a registered id ({exc}); allowed: a registered "
            f"Gymnasium id, {_some(ENV_SPECS)}"
        ) from None
    return env_id


def check_supervised(option: str, env_id: str, env: Any) -> None:
    """`env` (built from `env_id`) must answer `supervisor_action()`."""
    from fluids_bench.core.supervisor import has_supervisor
    from fluids_bench.registration import ENV_SPECS

    if not has_supervisor(env):
        raise ValueError(
            f"{option} is {env_id!r}, an env with no supervisor; allowed: an id whose env (or "
            f"wrapper) has supervisor_action(), {_some(ENV_SPECS)} (to bring an env, "
            "register one wrapped in fluids_bench.core.supervisor.SupervisorWrapper)"
        )


def _some(ids: Mapping[str, Any]) -> str:
    return "one of " + ", ".join(ids)
