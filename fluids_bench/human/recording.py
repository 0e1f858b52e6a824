"""Datasets people record (teleop) or label (relabel), and the env states stored with them.

A recorded dataset is a Minari dataset laid out as `fluids_bench.data.minari_export`'s
(`actions` are the labels, infos have `T + 1` rows with the reset's first, so a per-step
column's row `t + 1` belongs to step `t`), with these infos columns:

* `executed_action`: what the env executed at step `t` (the person's action, plus the
  injected noise under `--noise`);
* `provenance`: `"human"`, `"human_noise"` (a person acted, noise was added),
  `"simulated_human"` / `"simulated_human_noise"` (a simulated person), or what the source
  dataset said;
* `supervisor_action`: the algorithmic supervisor's label of the same state;
* `time`: seconds since the session started when the action was taken;
* `reaction_time`: seconds from showing the state to the person's first input after it
  (NaN when nothing changed while the state was shown);
* `noise_level`: the trace of the injected covariance (Box) or the probability of another
  action (Discrete), 0 without noise;
* `state_stored`: whether the env state of `observations[t]` is stored (row `t`).

`actions[t]` is the person's intended action (with noise injected, what they meant, not what
was executed). A relabelled dataset keeps the source's columns and adds `original_action`
(the source dataset's `actions`), `relabelled` (whether a person labelled the step; when
not, the action is the original) and `label_time` (seconds the person took).

The env states live next to Minari's `data` folder, in `fluids_bench_states/`: one file per
episode, `episode_N.npz`, in the safe state format (`fluids_bench.core.state_format`: a
JSON header listing the stored steps, and one entry per step holding that step's
`fluids_bench.core.snapshot.snapshot`, the wrapped env's state including its time limit
counter, as bytes; read with `allow_pickle=False`, never unpickled) for the observations whose
state was stored (every `snapshot_every` steps, and the first). Datasets written by older
versions stored `episode_N.pkl.gz` pickles instead: loading a pickle can run any code its
author put in it, so they are read only with `trust_pickle=True` (`--trust-pickle`), and
converted to the safe format on the way in. Any other step's state is rebuilt by
restoring the nearest stored state before it and re-executing the recorded actions (the envs
continue bit-identically); a dataset without stored states (e.g. from `fluids-bench
collect`) is replayed from its episode seeds. `StateRebuilder` does this and checks
every rebuilt observation against the recorded one.

Writing is atomic (staged in a hidden folder of the datasets root, then renamed into place, as
`export_minari`); appending to an existing id rewrites it with the old episodes first.
"""

from __future__ import annotations

import gzip
import json
import pickle
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import minari
import numpy as np
from gymnasium import spaces
from minari.data_collector import EpisodeBuffer

from fluids_bench.core import snapshot as snap
from fluids_bench.core.state_format import StateFormatError, pack, unpack
from fluids_bench.data.minari_export import check_dataset_id, dataset_path, write_staged

STATES_DIR = "fluids_bench_states"
SESSIONS_FILE = "sessions.json"  # in STATES_DIR: one record per teleop / relabel session
STATES_KIND = "episode-states"
TRUST_PICKLE_WHY = (
    "loading a pickle can run any code whoever made the file put in it; pass --trust-pickle "
    "(Python: trust_pickle=True) only for a dataset you made yourself or whose maker you trust "
    "(it is then converted to the safe format when written again)"
)


def states_to_bytes(states: dict[int, snap.WrappedSnapshot]) -> bytes:
    """An episode's stored states (observation index -> wrapped snapshot) in the safe state
    format (a compressed `.npz`)."""
    steps = sorted(states)
    arrays = [np.frombuffer(states[t].to_bytes(), dtype=np.uint8) for t in steps]
    return pack({"kind": STATES_KIND, "steps": steps}, arrays, compress=True)


def states_from_bytes(data: bytes, what: str) -> dict[int, snap.WrappedSnapshot]:
    """What `states_to_bytes` wrote, checked (`StateFormatError` naming `what`)."""
    meta, arrays = unpack(data, what)
    steps = meta.get("steps")
    if (
        meta.get("kind") != STATES_KIND
        or set(meta) != {"format", "kind", "steps"}
        or type(steps) is not list
        or not all(type(t) is int and t >= 0 for t in steps)
        or len(set(steps)) != len(steps)
    ):
        raise StateFormatError(f"{what}: not an episode's stored states (header {sorted(meta)})")
    if len(arrays) != len(steps):
        raise StateFormatError(f"{what}: {len(steps)} steps listed, {len(arrays)} stored")
    out = {}
    for t, array in zip(steps, arrays, strict=True):
        if array.dtype != np.uint8 or array.ndim != 1:
            raise StateFormatError(f"{what}: step {t}'s entry is not bytes")
        out[t] = snap.WrappedSnapshot.from_bytes(array.tobytes(), f"{what} step {t}")
    return out


def _legacy_states(path: Path, env: gym.Env) -> dict[int, snap.WrappedSnapshot]:
    """The pickled states an older fluids-bench wrote (trusted by the caller), converted into
    the safe format by restoring each into `env` the old way and snapshotting it again."""
    with gzip.open(path, "rb") as f:
        states = pickle.load(f)
    if not isinstance(states, dict):
        raise ValueError(f"{path}: expected a dict of states, got {type(states).__name__}")
    env.reset(seed=0)  # the old states refer to objects a reset env holds (the layout)
    return {int(t): snap.from_legacy(env, old) for t, old in states.items()}


@dataclass
class Episode:
    """One recorded episode: `observations` has `T + 1` rows, `actions` / `rewards`
    `T`; every `infos` column `T + 1` rows; `states` maps observation index to a
    wrapped snapshot."""

    seed: int | None
    observations: list[Any]
    actions: list[Any] = field(default_factory=list)
    rewards: list[float] = field(default_factory=list)
    infos: dict[str, list[Any]] = field(default_factory=dict)
    terminated: bool = False
    truncated: bool = False
    states: dict[int, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.actions)


def _column(values: list[Any]) -> Any:
    """A Minari info column: a list for scalars and strings (Minari 0.5.4's Arrow storage cannot
    read back 1-D arrays), an array for vectors."""
    first = values[0]
    if isinstance(first, np.ndarray) and first.ndim >= 1:
        return np.stack(values)
    if isinstance(first, np.str_ | str):
        return [str(v) for v in values]
    if isinstance(first, bool | np.bool_):
        return [bool(v) for v in values]
    if isinstance(first, int | np.integer):
        return [int(v) for v in values]
    return [float(v) for v in values]


def _observations(space: spaces.Space, rows: list[Any]) -> Any:
    if isinstance(space, spaces.Dict):
        return {k: _observations(sub, [r[k] for r in rows]) for k, sub in space.items()}
    return np.asarray(np.stack(rows), dtype=space.dtype)


def _actions(space: spaces.Space, values: list[Any]) -> np.ndarray:
    if isinstance(space, spaces.Discrete):
        return np.asarray(values, dtype=space.dtype).reshape(-1)
    return np.asarray(values, dtype=space.dtype).reshape((-1, *space.shape))


def episode_buffer(index: int, ep: Episode, obs_space, act_space) -> EpisodeBuffer:
    steps = len(ep)
    if steps == 0:
        raise ValueError(f"episode {index} has no steps; Minari episodes need at least one")
    for key, column in ep.infos.items():
        if len(column) != steps + 1:
            raise ValueError(f"episode {index}: info {key!r} has {len(column)} rows, not T + 1")
    terminations = np.zeros(steps, dtype=bool)
    truncations = np.zeros(steps, dtype=bool)
    terminations[-1] = ep.terminated
    truncations[-1] = not ep.terminated
    infos = {k: _column(list(v)) for k, v in ep.infos.items()}
    infos["state_stored"] = [t in ep.states for t in range(steps + 1)]
    return EpisodeBuffer(
        id=index,
        seed=None if ep.seed is None else int(ep.seed),
        observations=_observations(obs_space, ep.observations),
        actions=_actions(act_space, ep.actions),
        rewards=np.asarray(ep.rewards, dtype=np.float64),
        terminations=terminations,
        truncations=truncations,
        infos=infos,
    )


def env_spec(env: gym.Env) -> gym.envs.registration.EnvSpec:
    """The env's spec without `render_mode` (a dataset rebuilds its env headless)."""
    spec = env.spec
    kwargs = {k: v for k, v in spec.kwargs.items() if k != "render_mode"}
    return gym.envs.registration.EnvSpec(
        id=spec.id,
        entry_point=spec.entry_point,
        max_episode_steps=spec.max_episode_steps,
        kwargs=kwargs,
    )


def spec_of(dataset: minari.MinariDataset) -> gym.envs.registration.EnvSpec:
    spec = dataset.spec.env_spec
    if spec is None:
        raise ValueError(f"dataset {dataset.spec.dataset_id!r} stores no env spec")
    return spec


def load_episodes(dataset: minari.MinariDataset, *, trust_pickle: bool = False) -> list[Episode]:
    """Every episode of `dataset` with its infos and stored states (for append / relabel).

    States are read in the safe format (never unpickled). A dataset whose states are pickles
    (written by an older fluids-bench) raises `ValueError` unless `trust_pickle`."""
    root = Path(dataset.spec.data_path).parent / STATES_DIR
    legacy_env = None
    metadata = list(dataset.storage.get_episode_metadata(dataset.episode_indices))
    out = []
    for meta, ep in zip(metadata, dataset.iterate_episodes(), strict=True):
        infos = {}
        for key, value in (ep.infos or {}).items():
            if key == "state_stored" or isinstance(value, dict):
                continue
            infos[key] = list(value) if np.ndim(value) == 1 else [np.asarray(v) for v in value]
        states = {}
        path, legacy = root / f"episode_{ep.id}.npz", root / f"episode_{ep.id}.pkl.gz"
        if path.exists():
            states = states_from_bytes(path.read_bytes(), str(path))
        elif legacy.exists():
            if not trust_pickle:
                raise ValueError(
                    f"dataset {dataset.spec.dataset_id!r} stores its env states as pickles "
                    f"({legacy}, written by an older fluids-bench) and they are not loaded: "
                    f"{TRUST_PICKLE_WHY}"
                )
            if legacy_env is None:
                spec = spec_of(dataset)
                legacy_env = gym.make(spec.id, **spec.kwargs)
            states = _legacy_states(legacy, legacy_env)
        obs = ep.observations
        rows = (
            [{k: obs[k][t] for k in obs} for t in range(len(ep.actions) + 1)]
            if isinstance(obs, dict)
            else list(obs)
        )
        seed = meta.get("seed")
        out.append(
            Episode(
                seed=None if seed is None else int(seed),
                observations=rows,
                actions=list(ep.actions),
                rewards=[float(r) for r in ep.rewards],
                infos=infos,
                terminated=bool(ep.terminations[-1]),
                truncated=bool(ep.truncations[-1]),
                states=states,
            )
        )
    return out


def sessions(dataset_id: str) -> list[dict[str, Any]]:
    """The session records stored with a dataset (empty when none)."""
    path = dataset_path(dataset_id) / STATES_DIR / SESSIONS_FILE
    return json.loads(path.read_text()) if path.exists() else []


def check_writable(dataset_id: str, *, overwrite: bool = False, append: bool = False) -> bool:
    """Whether `dataset_id` exists; FileExistsError when it does and neither `overwrite`
    nor `append` is set; ValueError for a malformed id or both flags."""
    check_dataset_id(dataset_id)
    if overwrite and append:
        raise ValueError("pass --append or --overwrite, not both")
    exists = dataset_path(dataset_id).exists()
    if exists and not (overwrite or append):
        raise FileExistsError(
            f"dataset {dataset_id!r} already exists at {dataset_path(dataset_id)}; pass "
            "--append to add this session's episodes to it, or --overwrite to replace it"
        )
    return exists


def write_dataset(
    dataset_id: str,
    episodes: list[Episode],
    spec: gym.envs.registration.EnvSpec,
    *,
    session: dict[str, Any],
    append: bool = False,
    overwrite: bool = False,
    algorithm_name: str,
    description: str,
    data_format: str = "arrow",
    previous_sessions: list[dict[str, Any]] | None = None,
    trust_pickle: bool = False,
) -> minari.MinariDataset:
    """Write `episodes` (after the existing ones when `append`) atomically as
    `dataset_id`, with their states and the session record; returns the loaded dataset."""
    check_dataset_id(dataset_id)
    exists = check_writable(dataset_id, overwrite=overwrite, append=append)
    if not episodes:
        raise ValueError("no finished episodes to write")
    old: list[Episode] = []
    old_sessions: list[dict[str, Any]] = list(previous_sessions or [])
    if append and exists:
        previous = minari.load_dataset(dataset_id)
        old_spec = spec_of(previous)
        if (old_spec.id, old_spec.kwargs) != (spec.id, spec.kwargs):
            raise ValueError(
                f"--append: dataset {dataset_id!r} holds {old_spec.id} with kwargs "
                f"{old_spec.kwargs}, this session {spec.id} with {spec.kwargs}; append "
                "only sessions of the same env"
            )
        old = load_episodes(previous, trust_pickle=trust_pickle)
        old_sessions = sessions(dataset_id) + old_sessions
        # infos columns must agree across episodes: keep the common ones
        keys = set(episodes[0].infos)
        for ep in old:
            missing = keys - set(ep.infos)
            if missing:
                raise ValueError(
                    f"--append: the dataset's episodes lack info columns {sorted(missing)}"
                )
            ep.infos = {k: ep.infos[k] for k in episodes[0].infos}
    env = gym.make(spec.id, **spec.kwargs)
    obs_space, act_space = env.observation_space, env.action_space
    env.close()
    everything = old + list(episodes)
    buffers = [episode_buffer(i, ep, obs_space, act_space) for i, ep in enumerate(everything)]

    def add_states(folder: Path) -> None:
        states_dir = folder / STATES_DIR
        states_dir.mkdir()
        for i, ep in enumerate(everything):
            if ep.states:
                (states_dir / f"episode_{i}.npz").write_bytes(states_to_bytes(ep.states))
        (states_dir / SESSIONS_FILE).write_text(json.dumps(old_sessions + [session], indent=1))

    # an append or an asked-for overwrite replaces the old version; otherwise a dataset that
    # appeared meanwhile (another run's) is kept and this write refused
    return write_staged(
        dataset_id,
        buffers,
        overwrite=overwrite or (append and exists),
        add_files=add_states,
        env=spec,
        eval_env=spec,
        algorithm_name=algorithm_name,
        author="fluids-bench",
        observation_space=obs_space,
        action_space=act_space,
        description=description,
        data_format=data_format,
    )


def next_version(dataset_id: str) -> str:
    """`NAME-vK` → `NAME-v(K+1)`, skipping versions that exist."""
    namespace, name, version = check_dataset_id(dataset_id)
    prefix = f"{namespace}/{name}" if namespace else name
    version += 1
    while dataset_path(f"{prefix}-v{version}").exists():
        version += 1
    return f"{prefix}-v{version}"


def _same_observation(a: Any, b: Any) -> bool:
    if isinstance(a, dict):
        return all(_same_observation(a[k], b[k]) for k in a)
    return bool(np.array_equal(np.asarray(a), np.asarray(b)))


class StateRebuilder:
    """Puts an env into the state of any recorded observation (see the module docstring).

    `env` is built from the dataset's spec (`render_mode` as given). `go(episode, t)`
    restores the nearest stored state at or before `t` (or resets with the episode's seed),
    re-executes the recorded actions up to `t` and checks the observation; consecutive
    `t` of one episode step the env once."""

    def __init__(self, spec, episodes: list[Episode], dataset_id: str, render_mode=None):
        self.episodes = episodes
        self.dataset_id = dataset_id
        self.env = gym.make(spec.id, render_mode=render_mode, **spec.kwargs)
        self.env.reset(seed=0)  # Gymnasium's checker wrapper wants a reset before any step
        self.at: tuple[int, int] | None = None
        self.observation: Any = None
        for i, ep in enumerate(episodes):
            if not ep.states and ep.seed is None:
                raise ValueError(
                    f"dataset {dataset_id!r} stores no env states and episode {i} has no "
                    "seed, so its states cannot be shown; relabel needs a dataset recorded "
                    "by fluids-bench teleop (states stored) or one whose episodes replay "
                    "from their seeds (e.g. fluids-bench collect)"
                )

    def executed(self, ep: Episode, t: int) -> Any:
        column = ep.infos.get("executed_action")
        return ep.actions[t] if column is None else column[t + 1]

    def go(self, episode: int, t: int) -> Any:
        ep = self.episodes[episode]
        if self.at == (episode, t):
            return self.observation
        if self.at == (episode, t - 1):
            start, observation = t - 1, self.observation
        else:
            stored = [k for k in ep.states if k <= t]
            if stored:
                start = max(stored)
                snap.restore(self.env, ep.states[start])
                observation = ep.observations[start]
            else:
                start = 0
                observation, _ = self.env.reset(seed=ep.seed)
                if not _same_observation(observation, ep.observations[0]):
                    self._mismatch(episode, 0)
        for k in range(start, t):
            action = self.executed(ep, k)
            if isinstance(self.env.action_space, spaces.Discrete):
                action = int(action)
            observation, *_ = self.env.step(action)
            if not _same_observation(observation, ep.observations[k + 1]):
                self.at = None
                self._mismatch(episode, k + 1)
        self.at, self.observation = (episode, t), observation
        return observation

    def _mismatch(self, episode: int, t: int) -> None:
        raise ValueError(
            f"dataset {self.dataset_id!r}, episode {episode}: replaying the recorded actions "
            f"does not reproduce observation {t}; the dataset's stored states are missing or "
            "were recorded with another version of the env (relabel needs stored env states, "
            "or episodes that replay from their seeds)"
        )

    def close(self) -> None:
        self.env.close()
