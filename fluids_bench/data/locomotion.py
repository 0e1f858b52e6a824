"""Minari datasets of the locomotion supervisors, with their provenance and reference scores.

`export_supervisor_dataset` collects seeded episodes (optionally with isotropic noise on the
executed actions; the stored actions are always the supervisor's labels) and writes a Minari
dataset whose `description` is a JSON record of the supervisor (kind, recipe, weights sha256)
and whose `ref_min_score` / `ref_max_score` are the random policy's and the supervisor's
measured mean 1,000-step returns (the D4RL normalisation), from `metadata["reference_scores"]`
(stored only for the id's default supervisor, the one whose return was measured).
"""

from __future__ import annotations

import json
from typing import Any

import gymnasium as gym
import minari

from fluids_bench.data.collect import ActorSpec, collect
from fluids_bench.data.minari_export import export_minari


def export_supervisor_dataset(
    dataset_id: str,
    env_id: str,
    episodes: int,
    *,
    seed: int = 0,
    env_kwargs: dict[str, Any] | None = None,
    noise_std: float = 0.0,
    max_steps: int | None = None,
    workers: int = 1,
    overwrite: bool = False,
) -> minari.MinariDataset:
    """Collect `episodes` episodes of `env_id` (seeds `seed, seed + 1, ...`) and export them."""
    env_kwargs = dict(env_kwargs or {})
    env = gym.make(env_id, **env_kwargs)
    meta = env.unwrapped.metadata
    env.close()
    actor = ActorSpec("noise", noise_std=noise_std) if noise_std > 0 else ActorSpec()
    trajectories = collect(
        env_id,
        episodes,
        env_kwargs=env_kwargs,
        actor=actor,
        seed=seed,
        max_steps=max_steps,
        workers=workers,
        progress=False,
    )
    refs = meta["reference_scores"]
    measured = refs["supervisor"] is not None  # only the default supervisor's return is measured
    record = {
        "supervisor": meta["supervisor"],
        "reference_scores": refs,
        "gymnasium_env": meta["gymnasium_env"],
        "mujoco_version": meta["mujoco_version"],
        "acted_by": actor.describe(),
        "episode_seeds": [seed, seed + episodes - 1],
    }
    return export_minari(
        dataset_id,
        trajectories,
        env_id=env_id,
        env_kwargs=env_kwargs,
        provenance=actor.kind,
        algorithm_name=f"fluids-bench locomotion supervisor: {meta['supervisor']['kind']}",
        description=json.dumps(record, sort_keys=True),
        ref_min_score=refs["random"] if measured else None,
        ref_max_score=refs["supervisor"] if measured else None,
        overwrite=overwrite,
    )
