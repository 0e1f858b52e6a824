"""``.ci/run`` runs the README's set-up commands literally and in order (issue #10, defect 1:
CI must catch what a user following the README hits)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    setup = text.split("## Set-up", 1)[1].split("```bash", 1)[1].split("```", 1)[0]
    return [line for line in setup.splitlines() if line and not line.startswith("#")]


def test_ci_runs_the_readme_commands_in_order():
    commands = _readme_commands()
    assert len(commands) == 2
    script = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    positions = [script.find(command) for command in commands]
    assert all(p >= 0 for p in positions), (commands, positions)
    assert positions == sorted(positions)
    assert "MPLBACKEND=Agg" in script
    # and afterwards the installed command from outside the repository
    assert re.search(r"cd \"\$\(mktemp -d\)\" && fluids-bench --help", script)


def test_the_demo_output_folder_is_ignored_by_git():
    ignored = (ROOT / ".gitignore").read_text(encoding="utf-8").splitlines()
    assert "/fluids_demo/" in ignored
