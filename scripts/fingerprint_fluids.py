"""Fingerprints of seeded FLUIDS episodes, to show a refactor changed no behaviour.

For FLUIDS-v0 and the multi-agent env, at every action level and observation type, runs a few
seeded episodes whose actions are the supervisor's labels perturbed at random (a seeded
generator), and prints one SHA-256 per stream (observations, rewards, labels, infos) of each
configuration as JSON. Run it before and after a change and diff the outputs:
``python scripts/fingerprint_fluids.py > before.json``.
"""

from __future__ import annotations

import argparse
import hashlib
import json

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.tasks.fluids.multi_agent import parallel_env

LEVELS = ("behavior", "trajectory", "velocity", "control")
OBS = ("explicit", "birdseye", "qlidar")
NOISE = {"obs_noise": 0.05, "pixel_noise": 4.0, "lidar_noise": 0.05, "lidar_dropout": 0.1}


def _feed(h: hashlib._Hash, value) -> None:
    """Hash a value exactly (arrays by dtype, shape and bytes; containers in order)."""
    if isinstance(value, dict):
        for k in sorted(value, key=str):
            h.update(repr(k).encode())
            _feed(h, value[k])
    elif isinstance(value, list | tuple):
        h.update(b"[")
        for v in value:
            _feed(h, v)
        h.update(b"]")
    elif isinstance(value, np.ndarray | np.generic):
        a = np.asarray(value)
        h.update(f"{a.dtype}{a.shape}".encode())
        h.update(np.ascontiguousarray(a).tobytes())
    else:
        h.update(repr(value).encode())


BLIND = {"behavior": False}  # --blind-behavior: behaviour actions ignore the labels


def _perturb(label, space, rng, k):
    if isinstance(label, int) and BLIND["behavior"]:
        return int(rng.integers(space.n))  # the same actions whatever the labels say
    if k % 5 != 2:
        return label
    if isinstance(label, int):
        return int(rng.integers(space.n))
    noisy = label + rng.normal(0, 0.4, np.shape(label))
    return np.clip(noisy, space.low, space.high).astype(np.float32)


def single(level: str, obs: str, seed: int, steps: int, **kwargs) -> dict[str, str]:
    env = gym.make("FLUIDS-v0", action_level=level, obs_type=obs, num_cars=4, **NOISE, **kwargs)
    hs = {k: hashlib.sha256() for k in ("obs", "rewards", "labels", "infos")}
    rng = np.random.default_rng(seed)
    o, info = env.reset(seed=seed)
    for k in range(steps):
        _feed(hs["obs"], o)
        _feed(hs["labels"], info.pop("supervisor_action"))
        _feed(hs["infos"], info)
        label = env.unwrapped.supervisor_action()
        o, r, term, trunc, info = env.step(_perturb(label, env.action_space, rng, k))
        _feed(hs["rewards"], (r, term, trunc))
        if term or trunc:
            break
    _feed(hs["obs"], o)
    _feed(hs["labels"], info.pop("supervisor_action"))
    _feed(hs["infos"], info)
    return {"steps": k + 1, **{k: h.hexdigest()[:16] for k, h in hs.items()}}


def multi(level: str, obs: str, seed: int, steps: int) -> dict[str, str]:
    env = parallel_env(
        controlled_cars=3, num_cars=2, action_level=level, obs_type=obs, max_cycles=steps, **NOISE
    )
    hs = {k: hashlib.sha256() for k in ("obs", "rewards", "labels", "infos")}
    rng = np.random.default_rng(seed)
    o, infos = env.reset(seed=seed)
    k = 0
    while True:
        _feed(hs["obs"], o)
        _feed(hs["labels"], {a: i.pop("supervisor_action") for a, i in infos.items()})
        _feed(hs["infos"], infos)
        if not env.agents:
            break
        actions = {
            a: _perturb(env.supervisor_action(a), env.action_space(a), rng, k) for a in env.agents
        }
        o, r, term, trunc, infos = env.step(actions)
        _feed(hs["rewards"], (r, term, trunc))
        _feed(hs["obs"], env.state())
        k += 1
    return {"steps": k, **{k: h.hexdigest()[:16] for k, h in hs.items()}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--steps", type=int, default=120)
    parser.add_argument(
        "--blind-behavior",
        action="store_true",
        help="behaviour-level actions drawn without looking at the labels, so a change of the "
        "labels alone shows in the labels' hash only",
    )
    args = parser.parse_args()
    BLIND["behavior"] = args.blind_behavior
    out = {}
    for level in LEVELS:
        for obs in OBS:
            for seed in range(args.seeds):
                out[f"single/{level}/{obs}/{seed}"] = single(level, obs, seed, args.steps)
                out[f"multi/{level}/{obs}/{seed}"] = multi(level, obs, seed, args.steps)
    for level in LEVELS:  # full-length episodes: arrivals, collisions and is_success
        for seed in range(args.seeds):
            out[f"single-long/{level}/{seed}"] = single(level, "explicit", seed, 400)
            out[f"multi-long/{level}/{seed}"] = multi(level, "explicit", seed, 400)
            out[f"single-all/{level}/{seed}"] = single(level, "qlidar", seed, 600, done_when="all")
    print(json.dumps(out, indent=1, sort_keys=True))


if __name__ == "__main__":
    main()
