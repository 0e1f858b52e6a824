"""Supervisor-labelled episodes as Minari datasets (the Farama standard for offline data).

In an exported dataset:

* `actions` are the supervisor's labels: `actions[t]` is what the supervisor does in the
  state of `observations[t]`, whoever acted there;
* `infos["executed_action"]` and `infos["provenance"]` say what was actually executed and
  who chose it (`"supervisor"`, `"noise"` or `"learner"`). Infos follow Minari's layout,
  `T + 1` rows with the reset's first, so the action executed at step `t` is row `t + 1`
  (`infos["executed_action"][1:]` lines up with `actions`); row 0 holds a zero action with
  provenance `"reset"`;
* `terminations` / `truncations`: the last step is terminated when the env said so and
  truncated otherwise (time limit, or cut short by the collector's `max_steps`);
* the env spec (id, JSON-friendly kwargs, time limit) is stored, so
  `dataset.recover_environment()` rebuilds the same env; each episode's seed is in its
  metadata.

Writing is atomic: the dataset is built under a hidden staging folder in the datasets root
(`MINARI_DATASETS_PATH`), which Minari does not list, then renamed into place; an
interrupted export leaves no dataset behind. A staging folder is named after its host and
process; one whose process is gone (an export killed with SIGKILL, which runs no clean-up) is
removed by the next export. An existing id is refused unless `overwrite`
(`check_new_dataset` lets a caller refuse it before collecting anything).
Dict observation spaces are stored as Minari's dict of arrays, and images losslessly (no JPEG).
Everything works offline; the default storage is Arrow (`data_format="hdf5"` needs h5py, the
`hdf5` extra: `check_data_format` refuses it up front when h5py is missing).
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
import re
import shutil
import socket
import uuid
import warnings
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import minari
import numpy as np
from gymnasium import spaces
from minari.data_collector import EpisodeBuffer
from minari.namespace import create_namespace, list_local_namespaces
from minari.storage import get_dataset_path

from fluids_bench import __version__
from fluids_bench.algos.dataset import Trajectory
from fluids_bench.core.parallel import pid_alive
from fluids_bench.data.collect import PROVENANCES

EXECUTED_KEY = "executed_action"
PROVENANCE_KEY = "provenance"
RESET_PROVENANCE = "reset"
STAGING_DIR = ".fluids-bench-staging"  # hidden: Minari skips dot-folders when listing
DATA_FORMATS = ("arrow", "hdf5")
# Minari reminds about unset optional fields; an export without them is deliberate
_OPTIONAL_FIELD_WARNINGS = r"`(author|author_email|code_permalink)` is set to None"


# Minari's dataset id rule, ``[NAMESPACE/]NAME-vK`` (it has no public validator; its own regex
# is private). tests/data/test_minari_export.py checks that Minari parses the same ids.
DATASET_ID_RE = re.compile(
    r"^(?:(?P<namespace>[-_\w][-_\w/]*[-_\w]+)/)?(?P<dataset>[-_\w]+?)(?:-v(?P<version>\d+))?$"
)


def check_dataset_id(dataset_id: str) -> tuple[str | None, str, int]:
    """`(namespace, name, version)` of a Minari id `[NAMESPACE/]NAME-vK`, or ValueError."""
    match = DATASET_ID_RE.fullmatch(dataset_id) if isinstance(dataset_id, str) else None
    if match is None or match.group("version") is None:
        raise ValueError(
            f"dataset id is {dataset_id!r}; allowed: NAMESPACE/NAME-vK (letters, "
            "digits, '-', '_'; a namespace has at least two characters)"
        )
    return match.group("namespace"), match.group("dataset"), int(match.group("version"))


HDF5_MISSING = 'data_format "hdf5" needs h5py: pip install "fluids-bench[hdf5]"'


def check_data_format(data_format: str) -> None:
    """ValueError for an unknown format; ImportError naming the extra when the format's
    library is missing. Call it before collecting, not only before writing."""
    if data_format not in DATA_FORMATS:
        raise ValueError(f"data_format is {data_format!r}; allowed: {list(DATA_FORMATS)}")
    if data_format == "hdf5" and importlib.util.find_spec("h5py") is None:
        raise ImportError(HDF5_MISSING)


def datasets_root() -> Path:
    """The datasets root Minari uses now (`MINARI_DATASETS_PATH`, else its default)."""
    return Path(get_dataset_path())


def dataset_path(dataset_id: str) -> Path:
    """Where dataset `dataset_id` lives (or would) under the datasets root."""
    return Path(get_dataset_path()) / dataset_id


def check_new_dataset(dataset_id: str, overwrite: bool = False) -> None:
    """ValueError for a malformed id; `FileExistsError` when the dataset exists and
    `overwrite` is False. Call it before collecting, not only before writing."""
    check_dataset_id(dataset_id)
    final = dataset_path(dataset_id)
    if final.exists() and not overwrite:
        raise FileExistsError(
            f"dataset {dataset_id!r} already exists at {final}; "
            "pass --overwrite (overwrite=True) to replace it"
        )


def _staging_name() -> str:
    return f"{socket.gethostname()}.{os.getpid()}.{uuid.uuid4().hex}"


def remove_stale_staging(root: Path) -> list[Path]:
    """Remove the staging folders of exports whose process no longer runs on this host (and
    unnamed ones from older versions); returns what was removed. Folders of live exports, and
    of other hosts sharing the folder, are left alone."""
    staging_root = root / STAGING_DIR
    if not staging_root.is_dir():
        return []
    host = socket.gethostname()
    removed = []
    for folder in staging_root.iterdir():
        if folder.name.endswith("-old"):
            owner = folder.name[: -len("-old")]
        else:
            owner = folder.name
        parts = owner.rsplit(".", 2)
        if len(parts) == 3:
            owner_host, pid = parts[0], parts[1]
            if owner_host != host or not pid.isdigit() or pid_alive(int(pid)):
                continue
        shutil.rmtree(folder, ignore_errors=True)
        removed.append(folder)
    with contextlib.suppress(OSError):
        staging_root.rmdir()  # only when empty
    return removed


def _observations(space: spaces.Space, values: Any) -> Any:
    """Rows of observations as Minari stores them: an array, or a dict of arrays for Dict
    spaces (rollouts record Dict observations as a sequence of dicts)."""
    if isinstance(space, spaces.Dict):
        rows = list(values)
        return {key: _observations(sub, [row[key] for row in rows]) for key, sub in space.items()}
    return np.asarray(np.stack(list(values)), dtype=space.dtype)


def _actions(space: spaces.Space, values: Any) -> Any:
    if isinstance(space, spaces.Discrete):
        return np.asarray(values, dtype=space.dtype).reshape(-1)
    return np.asarray(values, dtype=space.dtype).reshape((-1, *space.shape))


def episode_buffer(
    index: int,
    trajectory: Trajectory,
    provenance: str,
    observation_space: spaces.Space,
    action_space: spaces.Space,
) -> EpisodeBuffer:
    """One Minari episode from a trajectory (see the module docstring for the layout)."""
    if provenance not in PROVENANCES:
        raise ValueError(f"provenance is {provenance!r}; allowed: {list(PROVENANCES)}")
    steps = len(trajectory)
    if steps == 0:
        raise ValueError(f"episode {index} has no steps; Minari episodes need at least one")
    executed = _actions(action_space, trajectory.actions)
    reset_row = np.zeros_like(executed[:1])
    executed = np.concatenate([reset_row, executed])
    if isinstance(action_space, spaces.Discrete):
        # a list: Minari 0.5.4's Arrow storage cannot read back 1-D array infos
        executed = [int(a) for a in executed]
    terminations = np.zeros(steps, dtype=bool)
    truncations = np.zeros(steps, dtype=bool)
    terminations[-1] = trajectory.terminated
    truncations[-1] = not trajectory.terminated
    return EpisodeBuffer(
        id=index,
        seed=int(trajectory.seed),
        observations=_observations(observation_space, trajectory.observations),
        actions=_actions(action_space, trajectory.labels),
        rewards=np.asarray(trajectory.rewards, dtype=np.float64),
        terminations=terminations,
        truncations=truncations,
        infos={EXECUTED_KEY: executed, PROVENANCE_KEY: [RESET_PROVENANCE] + [provenance] * steps},
    )


@contextlib.contextmanager
def _datasets_root(path: Path) -> Iterator[None]:
    """Point Minari at `path` for the duration (Minari reads the variable on every call)."""
    before = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(path)
    try:
        yield
    finally:
        if before is None:
            del os.environ["MINARI_DATASETS_PATH"]
        else:
            os.environ["MINARI_DATASETS_PATH"] = before


def export_minari(
    dataset_id: str,
    trajectories: Sequence[Trajectory],
    *,
    env_id: str,
    env_kwargs: dict[str, Any] | None = None,
    provenance: str = "supervisor",
    **options: Any,
) -> minari.MinariDataset:
    """Write `trajectories` of `gym.make(env_id, **env_kwargs)` as Minari dataset
    `dataset_id` and return it loaded from disk; `options` are `export_buffers`'s
    (metadata, `overwrite`, `data_format`).

    Reference scores are stored only when both are given (Minari would otherwise run 100
    random episodes to estimate the missing minimum). Raises `FileExistsError` when the id
    exists and `overwrite` is False, `ValueError` for a malformed id, an empty list, a
    half-given reference pair or env kwargs that are not JSON-friendly.
    """
    check_dataset_id(dataset_id)
    if not trajectories:
        raise ValueError("export_minari: no trajectories to export")
    _, observation_space, action_space = env_spaces(env_id, env_kwargs)
    buffers = [
        episode_buffer(i, t, provenance, observation_space, action_space)
        for i, t in enumerate(trajectories)
    ]
    return export_buffers(dataset_id, buffers, env_id=env_id, env_kwargs=env_kwargs, **options)


def env_spaces(
    env_id: str, env_kwargs: dict[str, Any] | None = None
) -> tuple[gym.envs.registration.EnvSpec, spaces.Space, spaces.Space]:
    """`(spec, observation space, action space)` of `gym.make(env_id, **env_kwargs)`;
    ValueError when the spec cannot be stored (kwargs that are not JSON-friendly)."""
    env = gym.make(env_id, **dict(env_kwargs or {}))
    spec, observation_space, action_space = env.spec, env.observation_space, env.action_space
    env.close()
    try:
        spec.to_json()
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"export_minari: the env spec of {env_id!r} cannot be stored ({exc}); "
            "env kwargs must be JSON-friendly"
        ) from exc
    return spec, observation_space, action_space


def export_buffers(
    dataset_id: str,
    buffers: Sequence[EpisodeBuffer],
    *,
    env_id: str,
    env_kwargs: dict[str, Any] | None = None,
    algorithm_name: str | None = None,
    description: str | None = None,
    author: str | None = "fluids-bench",
    author_email: str | None = None,
    code_permalink: str | None = None,
    ref_min_score: float | None = None,
    ref_max_score: float | None = None,
    overwrite: bool = False,
    data_format: str = "arrow",
    add_files: Callable[[Path], None] | None = None,
) -> minari.MinariDataset:
    """Write episode buffers (`episode_buffer`) of `gym.make(env_id, **env_kwargs)` as
    Minari dataset `dataset_id` (see `export_minari`); `add_files(folder)` may put
    files of its own next to Minari's."""
    check_dataset_id(dataset_id)
    if not buffers:
        raise ValueError("export_minari: no trajectories to export")
    if (ref_min_score is None) != (ref_max_score is None):
        raise ValueError("export_minari: pass both ref_min_score and ref_max_score, or neither")
    check_data_format(data_format)
    check_new_dataset(dataset_id, overwrite)
    spec, observation_space, action_space = env_spaces(env_id, env_kwargs)
    return write_staged(
        dataset_id,
        buffers,
        overwrite=overwrite,
        add_files=add_files,
        env=spec,
        eval_env=spec,
        algorithm_name=algorithm_name,
        author=author,
        author_email=author_email,
        code_permalink=code_permalink,
        observation_space=observation_space,
        action_space=action_space,
        ref_min_score=ref_min_score,
        ref_max_score=ref_max_score,
        description=description,
        data_format=data_format,
    )


def write_staged(
    dataset_id: str,
    buffers: Sequence[EpisodeBuffer],
    *,
    overwrite: bool,
    add_files: Callable[[Path], None] | None = None,
    **metadata: Any,
) -> minari.MinariDataset:
    """Build Minari dataset `dataset_id` from `buffers` in a staging folder, let
    `add_files(folder)` put files of its own next to Minari's, then rename it into place
    (see `_move_into_place`) and return it loaded. `metadata` goes to
    `minari.create_dataset_from_buffers`; images are stored losslessly."""
    namespace, _, _ = check_dataset_id(dataset_id)
    root = Path(get_dataset_path())
    final = root / dataset_id
    remove_stale_staging(root)
    staging = root / STAGING_DIR / _staging_name()
    try:
        with _datasets_root(staging), warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=_OPTIONAL_FIELD_WARNINGS)
            minari.create_dataset_from_buffers(
                dataset_id,
                buffers,
                jpeg_encoding=False,  # images stay exact (JPEG would be lossy)
                requirements=[f"fluids-bench>={__version__}"],
                **metadata,
            )
        if add_files is not None:
            add_files(staging / dataset_id)
        if namespace is not None and namespace not in list_local_namespaces():
            create_namespace(namespace)
        final.parent.mkdir(parents=True, exist_ok=True)
        aside = staging.with_name(staging.name + "-old")
        _move_into_place(staging / dataset_id, final, aside, overwrite)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        with contextlib.suppress(OSError):
            (root / STAGING_DIR).rmdir()  # only when no other export is staging
    return minari.load_dataset(dataset_id)


def _move_into_place(built: Path, final: Path, aside: Path, overwrite: bool) -> None:
    """Rename `built` to `final`. With `overwrite` an existing `final` is set aside
    first and removed after, or put back if the rename fails. Without it a dataset that
    appeared since the export began (another run's) is never replaced: the rename itself fails
    on a non-empty folder, so no check-then-act window is left."""
    replaced = overwrite and final.exists()
    if replaced:
        os.rename(final, aside)
    try:
        os.rename(built, final)
    except OSError as exc:
        if replaced:
            os.rename(aside, final)
        elif final.exists():
            raise FileExistsError(
                f"dataset at {final} appeared during the export (another run wrote it); "
                "it is kept, this export is discarded"
            ) from exc
        raise
    if replaced:
        shutil.rmtree(aside)
