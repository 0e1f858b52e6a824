"""numba's kernel cache goes to a user cache directory, never into the installed package.

A cache written next to the sources (numba's default when that folder is writable) ends up in
``site-packages/fluids_bench/**/__pycache__``, which pip does not own: after
``pip install . && fluids-bench demo`` a later ``pip install -e .`` left those folders behind as an
empty namespace package and ``fluids-bench --help`` failed outside the repository.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import fluids_bench
from fluids_bench.core.numba_cache import default_cache_dir, kernel_digest, use_user_cache_dir

PACKAGE = Path(fluids_bench.__file__).parent

# Compiles (or loads) every kernel family: world, dynamics, explicit + quasi-LIDAR sensors,
# velocity planner and PID.
SCRIPT = """
import gymnasium as gym
import fluids_bench
env = gym.make("FLUIDS-v0", obs_type=["explicit", "qlidar"], action_level="control")
_, info = env.reset(seed=0)
for _ in range(12):
    *_, info = env.step(info["supervisor_action"])
print(fluids_bench.__file__)
"""


def _cache_files(root: Path) -> list[Path]:
    return sorted(p for p in root.rglob("*") if p.suffix in (".nbi", ".nbc"))


# the sensors' kernels: called from Python on every step, so a copy without their cache files
# compiles them again (a few seconds; all the kernels cold take 75 s or more)
RECOMPILED = ("fluids_bench", "tasks", "fluids", "sim", "sensors")


def test_compiling_the_kernels_writes_nothing_into_the_package(tmp_path):
    """A copy of the package runs with a user cache holding this process's kernels except the
    sensors': it compiles those, and they go to the user cache, nothing into the package. (With
    numba's default, a cache next to the sources, it would compile all of them into the package's
    `__pycache__` folders: the sources' folder has no cache to load.)"""
    exec(SCRIPT, {})  # now this process's cache holds what SCRIPT needs
    src = tmp_path / "src"
    shutil.copytree(PACKAGE, src / "fluids_bench", ignore=shutil.ignore_patterns("__pycache__"))
    cache = tmp_path / "xdg" / "fluids-bench" / "numba" / kernel_digest(src / "fluids_bench")
    # (numba writes a cache file as NAME.tmp.UID, then renames it: another xdist worker may be
    # writing one now)
    shutil.copytree(os.environ["NUMBA_CACHE_DIR"], cache, ignore=shutil.ignore_patterns("*.tmp.*"))
    dropped = cache.joinpath(*RECOMPILED)
    assert _cache_files(dropped), "this process cached no sensor kernel"
    shutil.rmtree(dropped)
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env |= {
        "HOME": str(tmp_path / "home"),
        "XDG_CACHE_HOME": str(tmp_path / "xdg"),
        "PYTHONPATH": str(src),
        "PYTHONDONTWRITEBYTECODE": "1",  # so any __pycache__ below would be numba's
    }
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT], env=env, cwd=tmp_path, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().startswith(str(src))  # the copy ran, not the checkout
    assert _cache_files(src) == []
    assert [p for p in src.rglob("__pycache__")] == []
    # ...and the sensors' kernels were compiled again, into the user cache directory
    assert len(_cache_files(dropped)) >= 2


def test_an_edited_kernel_file_gets_a_new_cache_directory(tmp_path):
    """numba would keep a caller's machine code when only a kernel it calls changes: the
    cache directory is named by the kernel sources, so any kernel edit recompiles them all."""
    root = tmp_path / "fluids_bench"
    shutil.copytree(PACKAGE, root, ignore=shutil.ignore_patterns("__pycache__"))
    before = kernel_digest(root)
    (root / "cli.py").write_text((root / "cli.py").read_text() + "\n# not a kernel module\n")
    assert kernel_digest.__wrapped__(root) == before
    kernels = root / "tasks" / "fluids" / "sim" / "kernels.py"
    kernels.write_text(kernels.read_text() + "\n# an edited kernel module\n")
    assert kernel_digest.__wrapped__(root) != before


def test_cache_dir_follows_xdg_and_home_and_respects_the_users_choice():
    assert use_user_cache_dir({"NUMBA_CACHE_DIR": "/mine"}) == "/mine"
    env = {"XDG_CACHE_HOME": "/x"}
    ours = os.path.join("/x", "fluids-bench", "numba", kernel_digest())
    assert use_user_cache_dir(env) == ours
    assert env["NUMBA_CACHE_DIR"] == ours
    home = os.path.join(os.path.expanduser("~"), ".cache", "fluids-bench", "numba", kernel_digest())
    assert default_cache_dir({}) == home
    assert default_cache_dir({"XDG_CACHE_HOME": "relative/dir"}) == home  # XDG: absolute only
    assert use_user_cache_dir({"NUMBA_CACHE_DIR": ""}) == home  # empty means unset, as numba


def test_the_package_sets_it_for_this_process():
    assert os.environ["NUMBA_CACHE_DIR"]
    from numba.core import config

    assert config.CACHE_DIR == os.environ["NUMBA_CACHE_DIR"]


# one small FLUIDS kernel: compiled or loaded, and numba's own count of cache misses
SMALL_SCRIPT = """
import fluids_bench
from fluids_bench.tasks.fluids.sim.dynamics import wrap_angle
assert abs(wrap_angle(7.0) - (7.0 - 6.283185307179586)) < 1e-12
print(fluids_bench.__file__, wrap_angle.stats.cache_misses.get((wrap_angle.signatures or [()])[0], 0))
"""


def _run_copy(tmp_path: Path, where: str) -> subprocess.CompletedProcess:
    src = tmp_path / where
    if not src.exists():
        shutil.copytree(PACKAGE, src / "fluids_bench", ignore=shutil.ignore_patterns("__pycache__"))
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env |= {"XDG_CACHE_HOME": str(tmp_path / "xdg"), "PYTHONPATH": str(src)}
    out = subprocess.run(
        [sys.executable, "-c", SMALL_SCRIPT], env=env, cwd=tmp_path, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith(str(src))  # the copy ran
    return out


def test_the_cache_survives_a_reinstall_at_another_path(tmp_path):
    """`pip install .` then `pip install -e .`: the same sources at another path load the
    kernels compiled by the first (numba alone files them by the folder's absolute path)."""
    first = _run_copy(tmp_path, "site-packages")
    assert first.stdout.split()[-1] == "1"  # compiled
    assert first.stderr.count("compiling FLUIDS kernels, once, ~") == 1, first.stderr
    again = _run_copy(tmp_path, "checkout")
    assert again.stdout.split()[-1] == "0", again.stdout  # loaded from the cache
    assert "compiling" not in again.stderr
    roots = {p.parent for p in (tmp_path / "xdg").rglob("*.nbi")}
    assert len(roots) == 1 and roots.pop().parts[-4:] == ("fluids_bench", "tasks", "fluids", "sim")


def test_a_warm_cache_compiling_one_more_kernel_says_nothing(tmp_path):
    _run_copy(tmp_path, "first")
    script = SMALL_SCRIPT.replace("wrap_angle(7.0)", "wrap_angle(7)")  # a new signature (int)
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env |= {"XDG_CACHE_HOME": str(tmp_path / "xdg"), "PYTHONPATH": str(tmp_path / "first")}
    out = subprocess.run(
        [sys.executable, "-c", script], env=env, cwd=tmp_path, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    assert "compiling" not in out.stderr
