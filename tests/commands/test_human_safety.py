"""Honest human tools and safe datasets (issue #44).

`teleop` and `relabel` refuse to run without a display a person could see (unless the tests'
headless opt-in is set), a teleop session without any input is not saved, and a dataset's
stored states are never unpickled unless asked to: a crafted pickle does not run.
"""

from __future__ import annotations

import copyreg
import functools
import gzip
import io
import json
import pickle
from pathlib import Path

import minari
import numpy as np
import pytest

pygame = pytest.importorskip("pygame")

from fluids_bench.cli import main  # noqa: E402
from fluids_bench.core.snapshot import EnvSnapshot  # noqa: E402
from fluids_bench.human import session  # noqa: E402
from fluids_bench.human.recording import STATES_DIR  # noqa: E402
from fluids_bench.human.window import Window  # noqa: E402

GRID = ["--env", "GridWorld-v0", "--max-steps", "4"]


@pytest.fixture(autouse=True)
def datasets_root(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "datasets"))
    monkeypatch.delenv("FLUIDS_BENCH_HEADLESS", raising=False)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.delenv("SDL_VIDEODRIVER", raising=False)


def _record(dataset: str) -> Path:
    """A GridWorld teleop dataset recorded by a simulated person (no window); its states
    folder."""
    argv = ["teleop", *GRID, "--dataset", dataset, "--simulated-human", "delay=0,epsilon=0"]
    assert main(argv) == 0
    return Path(minari.load_dataset(dataset).spec.data_path).parent / STATES_DIR


@pytest.mark.parametrize(
    ("environ", "reason"),
    [
        ({}, "neither DISPLAY nor WAYLAND_DISPLAY is set"),
        ({"DISPLAY": ":0", "SDL_VIDEODRIVER": "offscreen"}, "SDL_VIDEODRIVER=offscreen"),
        ({"WAYLAND_DISPLAY": "wayland-0", "SDL_VIDEODRIVER": "dummy"}, "SDL_VIDEODRIVER=dummy"),
    ],
)
def test_teleop_and_relabel_refuse_without_a_display(environ, reason, monkeypatch, capsys):
    _record("tt/grid-v0")
    capsys.readouterr()
    for key, value in environ.items():
        monkeypatch.setenv(key, value)
    assert main(["teleop", *GRID, "--dataset", "tt/new-v0"]) == 2
    err = capsys.readouterr().err
    assert "fluids-bench teleop needs a person at a real display" in err and reason in err
    assert "--simulated-human" in err and "FLUIDS_BENCH_HEADLESS=1" in err
    assert "tt/new-v0" not in minari.list_local_datasets()
    assert main(["relabel", "tt/grid-v0"]) == 2
    assert "fluids-bench relabel needs a person at a real display" in capsys.readouterr().err


def test_a_window_refuses_when_sdl_falls_back_to_no_screen(monkeypatch):
    monkeypatch.setenv("DISPLAY", ":9999")  # set, but no X server answers: SDL goes offscreen
    with pytest.raises(ValueError, match="SDL picked its 'offscreen' video driver"):
        Window("test", "fluids-bench teleop")
    monkeypatch.setenv("FLUIDS_BENCH_HEADLESS", "1")
    Window("test", "fluids-bench teleop").close()


def test_a_session_without_input_is_not_saved(monkeypatch, capsys):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("FLUIDS_BENCH_HEADLESS", "1")
    monkeypatch.setattr(session, "Teleop", functools.partial(session.Teleop, script=lambda s: None))
    argv = ["teleop", *GRID, "--dataset", "tt/idle-v0", "--fps", "1000"]
    assert main(argv) == 1
    assert "received no input" in capsys.readouterr().err
    assert "tt/idle-v0" not in minari.list_local_datasets()


class _Payload:
    """Unpickling this creates the file `path` (what an attacker's code could do)."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self):
        return (open, (str(self.path), "w"))


def test_relabel_never_unpickles_a_crafted_state_file(tmp_path, capsys):
    states = _record("tt/grid-v0")
    marker = tmp_path / "pwned"
    (states / "episode_0.npz").unlink()
    with gzip.open(states / "episode_0.pkl.gz", "wb") as f:
        pickle.dump({0: _Payload(marker)}, f)
    capsys.readouterr()
    assert main(["relabel", "tt/grid-v0", "--simulated-human", "delay=0"]) == 2
    err = capsys.readouterr().err
    assert "stores its env states as pickles" in err and "--trust-pickle" in err
    assert "can run any code" in err
    assert not marker.exists()


def test_relabel_refuses_a_crafted_npz_with_a_pickled_array(tmp_path, capsys):
    states = _record("tt/grid-v0")
    marker = tmp_path / "pwned"
    buffer = io.BytesIO()
    meta = json.dumps({"format": "fluids-bench-state", "kind": "episode-states", "steps": [0]})
    entries = {"__meta__": np.frombuffer(meta.encode(), dtype=np.uint8)}
    entries["a0"] = np.array([_Payload(marker)], dtype=object)  # stored as a pickle
    np.savez(buffer, **entries)
    (states / "episode_0.npz").write_bytes(buffer.getvalue())
    capsys.readouterr()
    assert main(["relabel", "tt/grid-v0", "--simulated-human", "delay=0"]) == 2
    err = capsys.readouterr().err
    assert "episode_0.npz is damaged or not a fluids-bench state" in err
    assert not marker.exists()


def _legacy_pickle(states: dict) -> bytes:
    """`states` as an older fluids-bench pickled them (each env snapshot's state a pickle of
    the env's fields)."""
    import gymnasium as gym

    class OldPickler(pickle.Pickler):
        def reducer_override(self, obj):
            if isinstance(obj, EnvSnapshot):
                env = gym.make(obj.env_id)
                env.unwrapped.restore(obj)
                state = pickle.dumps(env.unwrapped._snapshot_state())
                old = {"env_class": obj.env_class, "env_id": obj.env_id, "kwargs": obj.kwargs}
                return (copyreg.__newobj__, (EnvSnapshot,), {**old, "state": state})
            return NotImplemented

    buffer = io.BytesIO()
    pickler = OldPickler(buffer)
    pickler.dump(states)
    return buffer.getvalue()


def test_trust_pickle_reads_old_states_and_writes_them_safely(capsys):
    from fluids_bench.human.recording import states_from_bytes

    states_dir = _record("tt/grid-v0")
    path = states_dir / "episode_0.npz"
    states = states_from_bytes(path.read_bytes(), str(path))
    path.unlink()
    (states_dir / "episode_0.pkl.gz").write_bytes(gzip.compress(_legacy_pickle(states)))
    argv = ["relabel", "tt/grid-v0", "--simulated-human", "delay=0"]
    assert main(argv) == 2  # refused without the opt-in
    assert main([*argv, "--trust-pickle"]) == 0
    out = Path(minari.load_dataset("tt/grid-v1").spec.data_path).parent / STATES_DIR
    converted = states_from_bytes((out / "episode_0.npz").read_bytes(), "converted")
    assert sorted(converted) == sorted(states)
    assert all(converted[t] == states[t] for t in states)
