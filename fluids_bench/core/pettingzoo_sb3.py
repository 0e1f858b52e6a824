"""A PettingZoo `ParallelEnv` as a stable-baselines3 `VecEnv`: one policy shared by every agent.

SuperSuit does the vectorising (`pettingzoo_env_to_vec_env_v1`: one sub-env per agent, which
needs a fixed agent set, e.g. FLUIDS' `black_death=True`; `concat_vec_envs_v1`: several
copies of the world). Two gaps of SuperSuit 3.11's stable-baselines3 path are filled here:

* its `ConcatVecEnv` has no `get_attr`, while stable-baselines3 asks every `VecEnv` for its
  `render_mode` with `get_attr` whenever it is wrapped (`VecMonitor`, and PPO's own monitor
  wrapper): on SuperSuit's own path each wrap warns "The `render_mode` attribute is not defined
  in your environment" and sets it to None;
* it has no `seed`, so there `PPO(..., seed=s)` raises `AttributeError`. Here `seed(s)` seeds the
  next reset as stable-baselines3 expects: copy `i` of the world is reset with seed `s + i`.

Needs SuperSuit (the `test` extra) and stable-baselines3 (the `train` extra).
"""

from __future__ import annotations

import importlib
from typing import Any


def _require(module: str, extra: str):
    try:
        return importlib.import_module(module)
    except ImportError as err:
        raise ImportError(f'{module} is needed here: pip install "fluids-bench[{extra}]"') from err


class _ConcatVecEnvForSB3:
    """Forwards everything to a SuperSuit `ConcatVecEnv` and adds `get_attr` and `seed`."""

    def __init__(self, venv: Any):
        self._venv = venv
        self._next_seed: int | None = None

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):  # not forwarded: keeps copy/pickle from recursing
            raise AttributeError(name)
        return getattr(self._venv, name)

    def get_attr(self, name: str, indices: Any = None) -> Any:
        # SuperSuit's SB3VecEnvWrapper expects one value (it repeats render_mode per env itself)
        return getattr(self._venv, name)

    def seed(self, seed: int | None = None) -> list[int | None]:
        self._next_seed = seed
        return [None if seed is None else seed + i for i in range(self._venv.num_envs)]

    def reset(self, seed: int | None = None, options: dict | None = None):
        if seed is None:
            seed, self._next_seed = self._next_seed, None
        return self._venv.reset(seed=seed, options=options)


def shared_policy_vec_env(parallel_env: Any, copies: int = 1):
    """A stable-baselines3 `VecEnv` over `copies` copies of `parallel_env` (built afresh from
    it by SuperSuit), one sub-env per agent and copy: `num_envs = copies × len(possible_agents)`.

    `copies` is an int >= 1. Wrap the result in `VecMonitor` for episode statistics.
    """
    if isinstance(copies, bool) or not isinstance(copies, int) or copies < 1:
        raise ValueError(f"copies must be an int >= 1, got {copies!r}")
    ss = _require("supersuit", "test")
    _require("stable_baselines3", "train")
    from supersuit.vector.sb3_vector_wrapper import SB3VecEnvWrapper

    vec = ss.pettingzoo_env_to_vec_env_v1(parallel_env)
    vec = ss.concat_vec_envs_v1(vec, copies, num_cpus=0, base_class="gymnasium")
    return SB3VecEnvWrapper(_ConcatVecEnvForSB3(vec))
