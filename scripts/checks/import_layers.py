"""The package's import graph and its floors (DESIGN.md, "Layout"), read with `ast`.

Floors, lowest first: `core`; `tasks` (each task alone); `registration` and the package root;
`algos`; `data`; `sweep`; `benchmark`; `human`; `commands`; `cli`. A module imports only its
own floor or lower ones, a task imports no other task, and no two modules import each other,
even through a chain or an import inside a function (function-level imports count too).
`tests/test_import_layers.py` asserts it and the Development page draws it
(`docs/_gen/architecture.py`). Run as a script, it prints every violation (exit 1 if any):

    python scripts/checks/import_layers.py
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import fluids_bench

PACKAGE = Path(fluids_bench.__file__).resolve().parent
FLOORS = (
    "core",
    "tasks",
    "registration",
    "algos",
    "data",
    "sweep",
    "benchmark",
    "human",
    "commands",
    "cli",
)
ROOT_FLOOR = "registration"  # `import fluids_bench` registers the ids: registration's floor


def module_files(root: Path, package: str) -> dict[str, Path]:
    """Every module of the package under `root`, by dotted name."""
    modules = {}
    for path in sorted(root.rglob("*.py")):
        parts = [package, *path.relative_to(root).with_suffix("").parts]
        if parts[-1] == "__init__":
            parts.pop()
        modules[".".join(parts)] = path
    return modules


def imported(module: str, path: Path, node: ast.AST) -> list[str]:
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if not isinstance(node, ast.ImportFrom):
        return []
    if node.level:  # relative: from the module's package, `level - 1` packages up
        base = module.split(".")[: None if path.name == "__init__.py" else -1]
        base = base[: len(base) - node.level + 1]
        source = ".".join(base + ([node.module] if node.module else []))
    else:
        source = node.module or ""
    return [source] + [f"{source}.{alias.name}" for alias in node.names]


def import_graph(root: Path, package: str) -> dict[str, set[str]]:
    """`module -> modules of the package it imports`, anywhere in its body (functions too)."""
    modules = module_files(root, package)
    graph: dict[str, set[str]] = {name: set() for name in modules}
    for module, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            for name in imported(module, path, node):
                while name not in modules and "." in name:  # `from a.b import function`
                    name = name.rsplit(".", 1)[0]
                if name in modules and name != module:
                    graph[module].add(name)
    return graph


def floor_of(module: str, package: str) -> tuple[int, str]:
    """`(floor index, unit)`: the unit is the task for `tasks.*`, else the floor's name."""
    parts = module.split(".")[1:]
    if not parts:
        return FLOORS.index(ROOT_FLOOR), ROOT_FLOOR
    if parts[0] == "tasks":
        return FLOORS.index("tasks"), ".".join(parts[:2])
    if parts[0] not in FLOORS:
        raise AssertionError(f"{module} is on no floor: add its folder to FLOORS ({FLOORS})")
    return FLOORS.index(parts[0]), parts[0]


def upward_imports(graph: dict[str, set[str]], package: str) -> list[str]:
    """Every import of a higher floor, or of another task."""
    bad = []
    for module, targets in sorted(graph.items()):
        floor, unit = floor_of(module, package)
        for target in sorted(targets):
            target_floor, target_unit = floor_of(target, package)
            if target_floor > floor:
                bad.append(f"{module} imports {target} (floor {FLOORS[target_floor]!r} is above)")
            elif target_floor == floor == FLOORS.index("tasks") and target_unit != unit:
                bad.append(f"{module} imports {target} (another task)")
    return bad


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    cycles.append(sorted(component))
    return cycles


def main() -> int:
    graph = import_graph(PACKAGE, "fluids_bench")
    problems = upward_imports(graph, "fluids_bench") + [
        "import cycle: " + " -> ".join(c) for c in import_cycles(graph)
    ]
    for line in problems:
        print(line)
    print(
        f"{len(graph)} modules, {sum(map(len, graph.values()))} imports, {len(problems)} problems"
    )
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
