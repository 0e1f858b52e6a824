"""Fingerprint of seeded FLUIDS episodes: one SHA-256 per (id, action level, obs family).

Each episode is driven by a seeded mix of the supervisor's label and random actions (so the ego
leaves the nominal path and the background drivers react to it), and everything the env returns
(observations, rewards, flags, supervisor labels, collisions, lights) is hashed. Run it before and
after a change that must not alter an id's behaviour and compare the JSON:

    python scripts/fingerprint_fluids.py --env FLUIDS-v0 --out before.json
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)

LEVELS = ("behavior", "trajectory", "velocity", "control")
OBS = ("explicit", "qlidar", ["qlidar", "explicit"])
# collision keys that describe the event itself (fault labels added later are not behaviour)
EVENT_KEYS = ("step", "a", "b", "kind")


def _feed(h, value) -> None:
    if isinstance(value, dict):
        for k in sorted(value):
            h.update(str(k).encode())
            _feed(h, value[k])
    elif isinstance(value, list | tuple):
        for v in value:
            _feed(h, v)
    elif isinstance(value, np.ndarray):
        h.update(str(value.dtype).encode() + str(value.shape).encode())
        h.update(np.ascontiguousarray(value).tobytes())
    else:
        h.update(repr(value).encode())


def _info_part(info: dict) -> dict:
    return {
        "label": info["supervisor_action"],
        "collisions": [{k: c[k] for k in EVENT_KEYS} for c in info["collisions"]],
        "arrived": info["ego_arrived"],
        "route": info["route"],
        "lights": info["lights"],
        "success": info.get("is_success"),
    }


def fingerprint(env_id: str, level: str, obs_type, seeds: range, **kwargs) -> str:
    h = hashlib.sha256()
    env = gym.make(env_id, action_level=level, obs_type=obs_type, **kwargs)
    for seed in seeds:
        rng = np.random.default_rng(seed)
        env.action_space.seed(seed)
        obs, info = env.reset(seed=seed)
        _feed(h, [obs, _info_part(info)])
        for _ in range(120):
            a = info["supervisor_action"] if rng.random() < 0.6 else env.action_space.sample()
            obs, r, term, trunc, info = env.step(a)
            _feed(h, [obs, r, term, trunc, _info_part(info)])
            if term or trunc:
                break
    env.close()
    return h.hexdigest()


def fingerprint_parallel(level: str, seeds: range, **kwargs) -> str:
    """The same for the multi-agent env (three controlled cars, two supervised)."""
    from fluids_bench.registration import make_parallel_env

    h = hashlib.sha256()
    env = make_parallel_env(
        "FLUIDS-MultiAgent-v0", controlled_cars=3, num_cars=2, action_level=level, **kwargs
    )
    for seed in seeds:
        rng = np.random.default_rng(seed)
        obs, infos = env.reset(seed=seed)
        for a in env.possible_agents:
            env.action_space(a).seed(seed)
        _feed(h, [obs, {a: i["supervisor_action"] for a, i in infos.items()}])
        for _ in range(120):
            if not env.agents:
                break
            acts = {
                a: infos[a]["supervisor_action"]
                if rng.random() < 0.6
                else env.action_space(a).sample()
                for a in env.agents
            }
            obs, rew, term, trunc, infos = env.step(acts)
            events = {
                a: [{k: c[k] for k in EVENT_KEYS} for c in i["collisions"]]
                for a, i in infos.items()
            }
            labels = {a: i["supervisor_action"] for a, i in infos.items()}
            _feed(h, [obs, rew, term, trunc, events, labels])
    return h.hexdigest()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="FLUIDS-v0")
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    out = {}
    for level in LEVELS:
        for obs_type in OBS:
            key = f"{args.env}/{level}/{obs_type if isinstance(obs_type, str) else '+'.join(obs_type)}"
            kw = {"num_cars": 5, "num_pedestrians": 3}
            out[key] = fingerprint(args.env, level, obs_type, range(args.seeds), **kw)
            print(key, out[key][:16], flush=True)
    if args.env == "FLUIDS-v0":
        for level in LEVELS:
            key = f"FLUIDS-MultiAgent-v0/{level}"
            out[key] = fingerprint_parallel(level, range(args.seeds), num_pedestrians=3)
            print(key, out[key][:16], flush=True)
    text = json.dumps(out, indent=1, sort_keys=True)
    if args.out:
        with open(f"{args.out}.tmp", "w") as f:
            f.write(text)
        os.replace(f"{args.out}.tmp", args.out)


if __name__ == "__main__":
    main()
