"""Small checks for typed configs and env kwargs.

Every failure raises `ValueError` naming where it happened, the field, the value and what is
allowed, in the same shape across the suite: `"<where>: field 'x' is 3; allowed: [0, 1]"`; an
unknown keyword argument raises `UnknownArgumentError`, a `TypeError` that is also a
`ValueError`.
"""

from __future__ import annotations

import functools
import inspect
import math
import numbers
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

# the largest reward magnitude a reward keyword argument may set: returns of 1,000-step episodes
# and value iteration's sums stay far from a float's overflow (1e308 made them inf)
REWARD_LIMIT = 1e6


def is_int(value: Any) -> bool:
    """An integer, Python or numpy (`np.int64(3)`), but not a bool (`True`, `np.True_`)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def is_real(value: Any) -> bool:
    """A real number, Python or numpy (`np.float32(0.1)`, `np.int64(3)`), but not a bool."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


def finite_float(value: Any) -> float | None:
    """`value` as a finite Python float, or None when it is not a real number (a bool is
    not), not finite, or an integer beyond a float's range (`10**400`)."""
    if not is_real(value):
        return None
    try:
        v = float(value)
    except OverflowError:
        return None
    return v if math.isfinite(v) else None


def fail(where: str, name: str, value: Any, allowed: str) -> None:
    """Raise the suite's standard config error."""
    raise ValueError(f"{where}: field '{name}' is {value!r}; allowed: {allowed}")


def check_int(where: str, name: str, value: Any, lo: int, hi: int | None = None) -> int:
    """`value` must be an integer (Python or numpy, not a bool) in `[lo, hi]` (`hi=None`:
    no upper bound); returns it as a Python int."""
    allowed = f"an integer in [{lo}, {'inf' if hi is None else hi}]"
    if not is_int(value):
        fail(where, name, value, allowed)
    if value < lo or (hi is not None and value > hi):
        fail(where, name, value, allowed)
    return int(value)


def check_float(
    where: str,
    name: str,
    value: Any,
    lo: float = -math.inf,
    hi: float = math.inf,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
) -> float:
    """`value` must be a finite real number (Python or numpy, not a bool) in the given interval
    (open or closed ends); returns it as a Python float."""
    left = "(" if lo_open else "["
    right = ")" if hi_open else "]"
    allowed = f"a finite number in {left}{lo}, {hi}{right}"
    v = finite_float(value)
    if v is None:
        fail(where, name, value, allowed)
    if v < lo or v > hi or (lo_open and v == lo) or (hi_open and v == hi):
        fail(where, name, value, allowed)
    return v


def check_bool(where: str, name: str, value: Any) -> bool:
    """`value` must be a bool (Python or numpy `np.bool_`); returns a Python bool."""
    if not isinstance(value, bool | np.bool_):
        fail(where, name, value, "true or false")
    return bool(value)


def check_choice(where: str, name: str, value: Any, choices: Iterable[Any]) -> Any:
    """`value` must be one of `choices`."""
    options = list(choices)
    if value not in options:
        fail(where, name, value, f"one of {options}")
    return value


class UnknownArgumentError(TypeError, ValueError):
    """An unknown keyword argument to an env (a misspelling, or a wrapper probing for an option).

    A `TypeError`, as Python raises for an unexpected keyword argument and as wrappers that probe
    constructors expect (TorchRL's `GymEnv` retries without `frameskip` when the message says
    "unexpected keyword argument 'frameskip'"); also a `ValueError`, for code that catches the
    suite's other argument errors."""


def unknown_arguments(where: str, unknown: Iterable[str], allowed: Iterable[str]) -> Exception:
    """The error for unknown keyword arguments `unknown` (`allowed` are the accepted ones):
    `"<where>: unknown argument(s) 'x'; allowed: [...] (__init__() got an unexpected keyword
    argument 'x')"`, the last part in Python's own words for the first unknown name."""
    names = sorted(unknown)
    listed = ", ".join(repr(k) for k in names)
    return UnknownArgumentError(
        f"{where}: unknown argument(s) {listed}; allowed: {sorted(allowed)} "
        f"(__init__() got an unexpected keyword argument {names[0]!r})"
    )


def reject_unknown_kwargs(init: Callable[..., None]) -> Callable[..., None]:
    """Decorate an env's `__init__` so a misspelled keyword argument (`action_levle=...`, as
    `gym.make` passes them) raises `UnknownArgumentError` (a `TypeError` and a `ValueError`)
    naming it and listing the allowed ones, instead of Python's bare `TypeError`."""
    params = inspect.signature(init).parameters.values()
    allowed = [
        p.name
        for p in params
        if p.name != "self" and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
    ]

    @functools.wraps(init)
    def checked(self, *args: Any, **kwargs: Any) -> None:
        unknown = set(kwargs) - set(allowed)
        if unknown:
            raise unknown_arguments(type(self).__name__, unknown, allowed)
        init(self, *args, **kwargs)

    return checked


def as_seed(seed: Any) -> Any:
    """A numpy integer seed (`np.int64(5)`, as `rng.integers` gives) as the Python int
    Gymnasium's `reset` requires; anything else unchanged, for Gymnasium's own check. Envs call
    it before `super().reset(seed=...)`: `seed=np.int64(5)` then seeds exactly as `seed=5`."""
    if isinstance(seed, np.integer):
        return int(seed)
    return seed
