"""The package layout's rules (DESIGN.md), checked on the source of every task folder:

* a task's world (``model.py``, ``sim.py`` or the ``sim/`` package) imports neither gymnasium
  nor pettingzoo: env classes are the thin adapters;
* no module of a task imports another task (what tasks share lives in ``fluids_bench.core``).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import fluids_bench

TASKS = Path(fluids_bench.__file__).parent / "tasks"
TASK_NAMES = sorted(p.name for p in TASKS.iterdir() if (p / "__init__.py").exists())
# Tasks whose world is a library's, held unchanged: locomotion wraps Gymnasium's own MuJoCo v5
# envs (DESIGN.md: "do not rewrite them"), so it has no world module of its own to check.
BORROWED_WORLDS = {"locomotion"}


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


def _world_modules(task: Path) -> list[Path]:
    files = [task / "model.py", task / "sim.py", *sorted((task / "sim").rglob("*.py"))]
    return [f for f in files if f.exists()]


@pytest.mark.parametrize("task", sorted(set(TASK_NAMES) - BORROWED_WORLDS))
def test_a_tasks_world_does_not_import_gymnasium(task):
    modules = _world_modules(TASKS / task)
    assert modules, f"tasks/{task} has no model.py, sim.py or sim/"
    for path in modules:
        bad = {n for n in _imports(path) if n.split(".")[0] in ("gymnasium", "pettingzoo")}
        assert not bad, f"{path.relative_to(TASKS)} imports {sorted(bad)}"


@pytest.mark.parametrize("task", TASK_NAMES)
def test_a_task_does_not_import_another_task(task):
    others = {f"fluids_bench.tasks.{t}" for t in TASK_NAMES if t != task}
    for path in sorted((TASKS / task).rglob("*.py")):
        bad = {n for n in _imports(path) if any(n == o or n.startswith(o + ".") for o in others)}
        assert not bad, f"{path.relative_to(TASKS)} imports {sorted(bad)}"
