"""``.ci/run`` runs the README's set-up commands literally and in order in a clean venv (issue #10,
defect 1: CI must catch what a user following the README hits), then installs the optional
pieces and runs the tests that need them (tests/train_extra.py)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import train_extra

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = (ROOT / ".ci" / "run").read_text(encoding="utf-8")


def _readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    setup = text.split("## Set-up", 1)[1].split("```bash", 1)[1].split("```", 1)[0]
    return [line for line in setup.splitlines() if line and not line.startswith("#")]


def _code(script: str = SCRIPT) -> str:
    """The script without its comments."""
    return "\n".join(line for line in script.splitlines() if not line.lstrip().startswith("#"))


def _at(needle: str) -> int:
    position = _code().find(needle)
    assert position >= 0, f".ci/run does not run {needle!r}"
    return position


def test_the_script_is_valid_bash():
    subprocess.run(["bash", "-n", str(ROOT / ".ci" / "run")], check=True)


def test_ci_runs_the_readme_commands_in_order():
    commands = _readme_commands()
    assert len(commands) == 2
    positions = [_at(command) for command in commands]
    assert positions == sorted(positions)
    assert "MPLBACKEND=Agg" in SCRIPT
    # and afterwards the installed command from outside the repository
    assert re.search(r"cd \"\$\(mktemp -d\)\" && fluids-bench --help", SCRIPT)


def test_the_readme_commands_run_first_in_a_clean_venv_without_the_optional_pieces():
    first = _at(_readme_commands()[0])
    assert _at('python3 -m venv "$venv"') < _at('source "$venv/bin/activate"') < first
    assert "--system-site-packages" not in _code()  # the system's torch must not leak in
    code = _code()[: _at(_readme_commands()[1])]
    for piece in ("torch", "stable-baselines3", "apt-get"):
        assert piece not in code, f"phase 1 installs {piece}"
    # the CI variables that turn skips into failures are unset until phase 2
    assert _at("unset FLUIDS_BENCH_BROWSER_TESTS FLUIDS_BENCH_TRAIN_TESTS") < first
    assert _code().count("export FLUIDS_BENCH") == 1


def test_phase_two_installs_the_optional_pieces_then_runs_the_marked_tests_with_skips_failing():
    second = _at(_readme_commands()[1])
    chromium = _at("apt-get install -y -qq chromium")
    torch = _at('pip install -q "torch==2.13.0" "stable-baselines3>=2.3"')
    strict = _at(f"export {train_extra.BROWSER_ENV}=1 {train_extra.TRAIN_ENV}=1")
    marked = _at('python3 -m pytest -q -n 2 -m "train_extra or browser or client_extra"')
    assert second < chromium < strict < marked and second < torch < strict


def test_phase_two_selects_every_marker_that_skips_a_test():
    # a new optional piece gets a marker in tests/conftest.py; phase 2 must select it too
    conftest = (ROOT / "tests" / "conftest.py").read_text(encoding="utf-8")
    markers = set(re.findall(r'"markers",\s*f?"(\w+):', conftest))
    markers -= {"fuzz_full"}  # the fuzz tests' full sets run on request, not in CI
    assert markers == {"train_extra", "browser", "client_extra"}
    selection = re.search(r'-m "([^"]+)"', _code()).group(1)
    assert set(selection.split(" or ")) == markers


def test_the_readme_says_how_long_the_tests_take_and_what_skips():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    setup = text.split("## Set-up", 1)[1].split("\n## ", 1)[0]
    assert re.search(r"\d+.\d+ minutes", setup)
    assert train_extra.REASON in setup
    assert "chromium" in setup


def test_the_demo_output_folder_is_ignored_by_git():
    ignored = (ROOT / ".gitignore").read_text(encoding="utf-8").splitlines()
    assert "/fluids_demo/" in ignored
