"""The package's floors hold (`scripts/checks/import_layers.py` reads the imports with `ast`):
no upward import, no task importing another, no import cycle, no private name imported across
modules, pools and Ray only in `core/parallel.py`; and the checks find what they look for."""

from __future__ import annotations

import ast
import sys
import textwrap
from pathlib import Path

import pytest
from script_module import load_script

LAYERS = load_script("checks/import_layers.py", "import_layers")
PACKAGE = LAYERS.PACKAGE
module_files = LAYERS.module_files
import_graph = LAYERS.import_graph
upward_imports = LAYERS.upward_imports
import_cycles = LAYERS.import_cycles
imported = LAYERS.imported


def test_no_module_imports_a_higher_floor_or_another_task() -> None:
    graph = import_graph(PACKAGE, "fluids_bench")
    assert upward_imports(graph, "fluids_bench") == []


def test_no_import_cycle() -> None:
    assert import_cycles(import_graph(PACKAGE, "fluids_bench")) == []


def test_parallel_execution_lives_in_core() -> None:
    """Pools and Ray sessions are started in `core/parallel.py` only."""
    found = []
    for module, path in module_files(PACKAGE, "fluids_bench").items():
        text = path.read_text()
        if module != "fluids_bench.core.parallel" and (
            "ProcessPoolExecutor(" in text or "ray.init(" in text
        ):
            found.append(module)
    assert found == []


def write_package(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        path = root / "pkg" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    return root / "pkg"


@pytest.mark.parametrize(
    ("files", "upward", "cycle"),
    [
        (  # a function-level import of a higher floor
            {
                "__init__.py": "",
                "core/__init__.py": "",
                "core/a.py": "def f():\n    from pkg.algos import b\n",
                "algos/__init__.py": "",
                "algos/b.py": "",
            },
            [
                "pkg.core.a imports pkg.algos (floor 'algos' is above)",
                "pkg.core.a imports pkg.algos.b (floor 'algos' is above)",
            ],
            [],
        ),
        (  # a circle on one floor, hidden in a function, with a relative import
            {
                "__init__.py": "",
                "commands/__init__.py": "",
                "commands/a.py": "from .b import x\n",
                "commands/b.py": "def x():\n    from pkg.commands.a import y\n",
            },
            [],
            [["pkg.commands.a", "pkg.commands.b"]],
        ),
        (  # one task importing another
            {
                "__init__.py": "",
                "tasks/__init__.py": "",
                "tasks/one/__init__.py": "from pkg.tasks.two import env\n",
                "tasks/two/__init__.py": "",
                "tasks/two/env.py": "",
            },
            [
                "pkg.tasks.one imports pkg.tasks.two (another task)",
                "pkg.tasks.one imports pkg.tasks.two.env (another task)",
            ],
            [],
        ),
    ],
)
def test_the_checks_find_what_they_look_for(
    tmp_path: Path, files: dict[str, str], upward: list[str], cycle: list[list[str]]
) -> None:
    graph = import_graph(write_package(tmp_path, files), "pkg")
    assert upward_imports(graph, "pkg") == upward
    assert import_cycles(graph) == cycle
    assert "pkg" not in sys.modules  # parsed, never imported


def test_no_private_name_is_imported_from_another_module() -> None:
    found = []
    for module, path in module_files(PACKAGE, "fluids_bench").items():
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and imported(module, path, node):
                names = [a.name for a in node.names if a.name.startswith("_")]
                source = imported(module, path, node)[0]
                if source.startswith("fluids_bench") and not all(n.startswith("__") for n in names):
                    found.append(f"{module} imports {names} from {source}")
    assert found == []
