"""Seeded episodes stepped B at a time on an id's vector env, each equal to its scalar rollout.

`run_vector_episodes(env_id, kwargs, seeds, act, ...)` runs one episode per seed on
`gym.make_vec(env_id, B, vectorization_mode="vector_entry_point")` (the FLUIDS ids have one):
world `w` holds one episode at a time, reset with that episode's seed (`reset(seed=[...],
options={"reset_mask": ...})`, the vector env's `"Disabled"` autoreset mode), and the next seed
takes its world as soon as it ends, so episodes that end at different steps keep the batch full.
Each episode is the scalar env's `reset(seed=s)` followed by the same actions: the vector env
returns world by world what the scalar env returns (tested in `tests/tasks/fluids/`), and
`act` is given each episode's own observation, supervisor label and generator, so an episode's
result does not depend on B or on which episodes share its batch.

When no seed is left and at most half the worlds still hold an episode, those episodes move
into a vector env of half the size (`snapshot(i)` / `restore(i, snap)`, which continue a world
bit for bit), so the last episodes do not step idle worlds; a world without an episode before
that runs a throwaway episode (its results are dropped).

An episode's end is reported to `on_end` at once, as an
[`EpisodeEnd`][fluids_bench.algos.vector_rollout.EpisodeEnd] (so a caller can write it
before the next one ends).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from fluids_bench.algos.dataset import Trajectory
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY

COLLISIONS_KEY = "collisions"
DEFAULT_BATCH = 32  # worlds stepped together (docs/benchmarks/performance.md)

# (the env's single action space, then the observations, supervisor labels and generators of
# the episodes that act this step, one entry each) -> their actions, one each
BatchActor = Callable[[gym.Space, list[Any], list[Any], list[np.random.Generator]], Sequence[Any]]


@dataclass
class EpisodeEnd:
    """One finished episode.

    Attributes:
        index: the episode's position in `seeds`.
        seed: its reset seed.
        total_return: the sum of its rewards, added in step order as Python floats.
        rewards: its rewards, in step order.
        length: its steps.
        terminated: it ended by termination.
        truncated: it ended by the id's time limit (neither: stopped at `max_steps`).
        info: the info of its last step (the reset's if it took none), as the scalar env
            returns it up to number types (numpy scalars where the scalar env has Python ones).
        collisions: the collision events listed in its infos (`info["collisions"]`), reset's
            included; None when no info has the key.
    """

    index: int
    seed: int
    total_return: float
    rewards: list[float]
    length: int
    terminated: bool
    truncated: bool
    info: dict[str, Any]
    collisions: int | None
    recorded: _Record | None = None  # with `record=True`: every step's data


@dataclass
class _Record:
    """An episode's observations (T + 1), actions, labels (T) and infos (T + 1)."""

    observations: list[Any] = field(default_factory=list)
    actions: list[Any] = field(default_factory=list)
    labels: list[Any] = field(default_factory=list)
    infos: list[dict[str, Any]] = field(default_factory=list)


def trajectory(end: EpisodeEnd) -> Trajectory:
    """The `Trajectory` of an episode run with `record=True`: the one `rollout` records for
    its seed, with infos equal up to number types (numpy scalars for Python ones)."""
    if end.recorded is None:
        raise ValueError("trajectory: the episode was run without record=True")
    r = end.recorded
    return Trajectory(
        observations=np.stack(r.observations),
        actions=np.asarray(r.actions),
        labels=np.asarray(r.labels),
        rewards=np.asarray(end.rewards, dtype=np.float64),
        infos=r.infos,
        terminated=end.terminated,
        truncated=end.truncated,
        seed=end.seed,
    )


def has_vector_env(env_id: str) -> bool:
    """Whether `env_id` has a vector entry point that can move a world between envs
    (`snapshot` / `restore`): the FLUIDS single-agent ids."""
    try:
        spec = gym.spec(env_id)
    except gym.error.Error:
        return False
    return spec.vector_entry_point is not None and "fluids" in str(spec.vector_entry_point)


def world_info(info: dict[str, Any], i: int) -> dict[str, Any]:
    """World `i`'s entries of a vector info (Gymnasium's layout: arrays with `_key` masks,
    nested dicts batched alike)."""
    out: dict[str, Any] = {}
    for key, value in info.items():
        if key.startswith("_"):
            continue
        mask = info.get(f"_{key}")
        if mask is None or not mask[i]:
            continue
        if isinstance(value, dict):
            out[key] = world_info(value, i)
        else:
            item = value[i]
            out[key] = item.copy() if isinstance(item, np.ndarray) else item
    return out


def _count(collisions: int | None, info: dict[str, Any]) -> int | None:
    """`collisions` plus the events `info` lists (None while no info has the key)."""
    if COLLISIONS_KEY not in info:
        return collisions
    events = info[COLLISIONS_KEY]
    new = int(events) if isinstance(events, int | np.integer) else len(events)
    return (collisions or 0) + new


@dataclass
class _Episode:
    index: int
    seed: int
    rng: np.random.Generator
    observation: Any
    info: dict[str, Any]
    total: float = 0.0
    length: int = 0
    collisions: int | None = None
    rewards: list[float] = field(default_factory=list)
    recorded: _Record | None = None


class _Batch:
    """A vector env of `n` worlds and the episode each world holds (None: a throwaway)."""

    def __init__(self, env_id: str, kwargs: dict[str, Any], n: int, record: bool) -> None:
        self.record = record
        self.env = gym.make_vec(
            env_id, n, vectorization_mode="vector_entry_point", autoreset_mode="Disabled",
            **kwargs,
        )  # fmt: skip
        self.n = n
        self.episodes: list[_Episode | None] = [None] * n
        self.labels: list[Any] = [None] * n  # each world's current label (a throwaway's too)
        self.space = self.env.single_action_space

    def reset(self, seeds: dict[int, int | None]) -> tuple[Any, dict[str, Any]]:
        """Reset the worlds `seeds` names, each with its seed (None: a throwaway's)."""
        mask = np.zeros(self.n, np.bool_)
        mask[list(seeds)] = True
        listed = [seeds.get(i) for i in range(self.n)]
        return self.env.reset(seed=listed, options={"reset_mask": mask})

    def label(self, info: dict[str, Any], i: int) -> Any:
        """World `i`'s supervisor label in `info`, else asked of its world."""
        if (
            info.get(f"_{SUPERVISOR_ACTION_KEY}") is not None
            and info[f"_{SUPERVISOR_ACTION_KEY}"][i]
        ):
            item = info[SUPERVISOR_ACTION_KEY][i]
            return item.copy() if isinstance(item, np.ndarray) else item
        return self.env.call("supervisor_action")[i]

    def close(self) -> None:
        self.env.close()


def run_vector_episodes(
    env_id: str,
    env_kwargs: dict[str, Any],
    seeds: Sequence[int],
    act: BatchActor,
    rng_for: Callable[[int], np.random.Generator],
    on_end: Callable[[EpisodeEnd], None],
    *,
    batch: int = DEFAULT_BATCH,
    max_steps: int | None = None,
    record: bool = False,
) -> None:
    """Run one episode per seed of `seeds` on `env_id`'s vector env, B worlds at a time.

    Args:
        env_id: a registered id with a vector entry point (`has_vector_env`).
        env_kwargs: its kwargs (as `gym.make`'s).
        seeds: each episode's reset seed.
        act: the actions of the acting episodes from the action space and their
            observations, labels and generators (see `BatchActor`).
        rng_for: each episode's generator from its seed (the scalar rollout's).
        on_end: called with each finished episode, as it finishes.
        batch: the most worlds stepped together (B).
        max_steps: stop an episode after this many steps (None: at its end).
        record: keep every step's data in `EpisodeEnd.recorded` (see `trajectory`).
    """
    if isinstance(batch, bool) or not isinstance(batch, int) or batch < 1:
        raise ValueError(f"batch is {batch!r}; allowed: a positive integer")
    pending = list(enumerate(int(s) for s in seeds))[::-1]  # popped from the end, in order
    if not pending:
        return
    current = _Batch(env_id, dict(env_kwargs), min(batch, len(pending)), record)
    try:
        _fill(current, pending, rng_for, on_end, max_steps, range(current.n))
        while any(e is not None for e in current.episodes):
            current = _shrink(current, env_id, env_kwargs, pending)
            _step(current, act, pending, rng_for, on_end, max_steps)
    finally:
        current.close()


def _fill(batch, pending, rng_for, on_end, max_steps, worlds) -> None:
    """Give each of `worlds` the next episode (a throwaway when none is left) and reset them;
    an episode that may take no step (`max_steps=0`) ends at once."""
    worlds = list(worlds)
    while worlds:
        seeds: dict[int, int | None] = {}
        for w in worlds:
            if pending:
                index, seed = pending.pop()
                batch.episodes[w] = _Episode(index, seed, rng_for(seed), None, {})
                if batch.record:
                    batch.episodes[w].recorded = _Record()
                seeds[w] = seed
            else:
                batch.episodes[w] = None
                seeds[w] = None
        observations, info = batch.reset(seeds)
        again = []
        for w in worlds:
            batch.labels[w] = batch.label(info, w)
            episode = batch.episodes[w]
            if episode is None:
                continue
            episode.observation = _row(observations, w)
            episode.info = world_info(info, w)
            episode.collisions = _count(episode.collisions, episode.info)
            if episode.recorded is not None:
                episode.recorded.observations.append(episode.observation)
                episode.recorded.infos.append(episode.info)
            if max_steps is not None and max_steps <= 0:
                _end(batch, w, False, False, on_end)
                again.append(w)
        worlds = again if pending else []


def _step(batch, act, pending, rng_for, on_end, max_steps) -> None:
    """One step of every world; the episodes that end are reported, their worlds refilled."""
    live = [w for w, e in enumerate(batch.episodes) if e is not None]
    episodes = [batch.episodes[w] for w in live]
    chosen = act(
        batch.space,
        [e.observation for e in episodes],
        [batch.labels[w] for w in live],
        [e.rng for e in episodes],
    )
    actions = list(batch.labels)  # a throwaway episode follows its supervisor
    for w, action in zip(live, chosen, strict=True):
        actions[w] = action
    observations, rewards, terminated, truncated, info = batch.env.step(_stack(actions))
    ended = []
    for w in range(batch.n):
        episode = batch.episodes[w]
        if episode is not None and episode.recorded is not None:
            episode.recorded.actions.append(actions[w])
            episode.recorded.labels.append(batch.labels[w])
        batch.labels[w] = batch.label(info, w)
        if episode is None:
            if terminated[w] or truncated[w]:
                ended.append(w)
            continue
        episode.observation = _row(observations, w)
        episode.info = world_info(info, w)
        reward = float(rewards[w])
        episode.total += reward
        episode.rewards.append(reward)
        episode.length += 1
        episode.collisions = _count(episode.collisions, episode.info)
        if episode.recorded is not None:
            episode.recorded.observations.append(episode.observation)
            episode.recorded.infos.append(episode.info)
        stop = max_steps is not None and episode.length >= max_steps
        if terminated[w] or truncated[w] or stop:
            _end(batch, w, bool(terminated[w]), bool(truncated[w]), on_end)
            ended.append(w)
    if ended:
        _fill(batch, pending, rng_for, on_end, max_steps, ended)


def _end(batch, w, terminated, truncated, on_end) -> None:
    episode = batch.episodes[w]
    batch.episodes[w] = None
    on_end(
        EpisodeEnd(
            episode.index, episode.seed, episode.total, episode.rewards, episode.length,
            terminated, truncated, episode.info, episode.collisions, episode.recorded,
        )
    )  # fmt: skip


def _shrink(batch: _Batch, env_id, env_kwargs, pending) -> _Batch:
    """With no seed left and at most half the worlds holding an episode, those episodes in a
    vector env of their number (each world moved by snapshot and restore); else `batch`."""
    live = [w for w, e in enumerate(batch.episodes) if e is not None]
    if pending or batch.n == 1 or len(live) > batch.n // 2:
        return batch
    smaller = _Batch(env_id, dict(env_kwargs), len(live), batch.record)
    try:
        for new, old in enumerate(live):
            smaller.env.restore(new, batch.env.snapshot(old))
            smaller.episodes[new] = batch.episodes[old]
            smaller.labels[new] = batch.labels[old]
    except BaseException:
        smaller.close()
        raise
    batch.close()
    return smaller


def _row(observations: Any, w: int) -> Any:
    if isinstance(observations, dict):
        return {key: value[w].copy() for key, value in observations.items()}
    return observations[w].copy()


def _stack(actions: list[Any]) -> np.ndarray:
    return np.stack([np.asarray(a) for a in actions])
