"""Fingerprints of seeded episodes: one SHA-256 per configuration, printed as JSON.

Runs seeded episodes of every registered id (FLUIDS at every action level and observation
family, noise on, several layouts; the v1 ids; GridWorld; DAG; the multi-agent env) under the
supervisor's labels with seeded perturbations (so episodes leave the nominal path), and hashes everything
the env returns: observations, rewards, terminated/truncated, infos (labels included). Uses only
the public API (``gym.make`` ids and kwargs, ``make_parallel_env``), so the same script runs on
an older checkout: compare two revisions with

    PYTHONPATH=/path/to/old python scripts/checks/fingerprint_episodes.py > old.json
    PYTHONPATH=. python scripts/checks/fingerprint_episodes.py > new.json
    diff old.json new.json

Same machine and install required (see the README's Reproducibility section).
"""

from __future__ import annotations

import argparse
import hashlib
import importlib
import json
from typing import Any

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core.provenance import announce

LEVELS = ("behavior", "trajectory", "velocity", "control")
OBS = ("explicit", "birdseye", "qlidar", ["explicit", "qlidar"])
NOISE = {"obs_noise": 0.1, "pixel_noise": 0.05, "lidar_noise": 0.2, "lidar_dropout": 0.1}


def _feed(h, value: Any) -> None:
    """Hash ``value`` canonically: types, dtypes, shapes and bytes; dict keys sorted."""
    if isinstance(value, dict):
        h.update(b"{")
        for key in sorted(value, key=str):
            _feed(h, str(key))
            _feed(h, value[key])
        h.update(b"}")
    elif isinstance(value, list | tuple):
        h.update(b"[%d" % len(value))
        for item in value:
            _feed(h, item)
        h.update(b"]")
    elif isinstance(value, np.ndarray | np.generic):
        arr = np.asarray(value)
        h.update(f"{arr.dtype.str}{arr.shape}".encode())
        h.update(np.ascontiguousarray(arr).tobytes())
    else:
        h.update(f"{type(value).__name__}:{value!r}".encode())


def _perturb(space: gym.Space, label: Any, rng: np.random.Generator, k: int) -> Any:
    if k % 7 != 3:
        return label
    if isinstance(space, gym.spaces.Discrete):
        return int(rng.integers(space.n))
    noisy = label + rng.normal(0.0, 0.3, np.shape(label))
    return np.clip(noisy, space.low, space.high).astype(space.dtype)


def episode_hash(env_id: str, seed: int, steps: int, **kwargs: Any) -> str:
    env = gym.make(env_id, **kwargs)
    rng = np.random.default_rng(seed)
    h = hashlib.sha256()
    obs, info = env.reset(seed=seed)
    _feed(h, [obs, info])
    for k in range(steps):
        out = env.step(_perturb(env.action_space, info["supervisor_action"], rng, k))
        _feed(h, list(out))
        info = out[4]
        if out[2] or out[3]:
            obs, info = env.reset(seed=seed + 1000 + k)
            _feed(h, [obs, info])
    env.close()
    return h.hexdigest()


def parallel_hash(seed: int, steps: int, env_id: str = "FLUIDS-MultiAgent-v0") -> str:
    for module in ("fluids_bench.registration", "fluids_bench.envs.registration"):
        try:
            make = importlib.import_module(module).make_parallel_env
            break
        except (ImportError, AttributeError):
            continue
    env = make(env_id, controlled_cars=4, num_cars=2, obs_noise=0.1)
    rng = np.random.default_rng(seed)
    h = hashlib.sha256()
    obs, infos = env.reset(seed=seed)
    _feed(h, [obs, infos])
    for k in range(steps):
        if not env.agents:
            break
        actions = {
            a: _perturb(env.action_space(a), infos[a]["supervisor_action"], rng, k)
            for a in env.agents
        }
        out = env.step(actions)
        _feed(h, [list(out), env.state()])
        infos = out[4]
    return h.hexdigest()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=2, help="episodes per configuration")
    parser.add_argument("--steps", type=int, default=150, help="steps per configuration")
    args = parser.parse_args()
    announce("a few minutes on one core")
    out: dict[str, str] = {}
    seeds = range(args.seeds)
    for level in LEVELS:
        for obs in OBS:
            name = f"FLUIDS-v0 {level} {obs}"
            kw = {"action_level": level, "obs_type": obs, "num_cars": 5, "num_pedestrians": 3}
            out[name] = "".join(
                episode_hash("FLUIDS-v0", s, args.steps, **kw, **NOISE)[:16] for s in seeds
            )
    for layout in ("t_junction", "roundabout"):
        kw = {"layout": layout, "num_cars": 5, "num_pedestrians": 3, "obs_type": "qlidar"}
        out[f"FLUIDS-v0 control {layout}"] = "".join(
            episode_hash("FLUIDS-v0", s, args.steps, **kw)[:16] for s in seeds
        )
    out["FLUIDS-v0 ompl planner"] = "".join(
        episode_hash("FLUIDS-v0", s, args.steps, trajectory_planner="ompl")[:16] for s in seeds
    )
    for env_id in ("FLUIDS-Sensitivity-v0", "GridWorld-v0", "DAG-v0"):
        out[env_id] = "".join(episode_hash(env_id, s, args.steps)[:16] for s in seeds)
    out["FLUIDS-MultiAgent-v0"] = "".join(parallel_hash(s, args.steps)[:16] for s in seeds)
    # the v1 ids as registered (their defaults), and at the velocity level
    for env_id in ("FLUIDS-v1", "FLUIDS-Sensitivity-v1"):
        out[env_id] = "".join(episode_hash(env_id, s, args.steps)[:16] for s in seeds)
    out["FLUIDS-v1 velocity qlidar"] = "".join(
        episode_hash("FLUIDS-v1", s, args.steps, action_level="velocity", obs_type="qlidar")[:16]
        for s in seeds
    )
    out["FLUIDS-MultiAgent-v1"] = "".join(
        parallel_hash(s, args.steps, "FLUIDS-MultiAgent-v1")[:16] for s in seeds
    )
    # every other registered FLUIDS id as registered (v2 and later): a new id appears as an
    # added line when two revisions are compared, a changed one as a changed line
    for env_id in sorted(gym.registry):
        if env_id.startswith("FLUIDS-") and env_id not in out and not env_id.endswith(("v0", "v1")):
            out[env_id] = "".join(episode_hash(env_id, s, args.steps)[:16] for s in seeds)
    import pettingzoo

    for env_id in sorted(getattr(pettingzoo, "parallel_registry", {})):
        if env_id.startswith("FLUIDS-") and env_id not in out:
            out[env_id] = "".join(parallel_hash(s, args.steps, env_id)[:16] for s in seeds)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
