"""The Development page's architecture picture (`docs/_gen/architecture.py`) is drawn from the
package's imports: every floor and every FLUIDS module is in it, and every group sits above the
groups it imports."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "docs" / "_gen"))

import architecture  # noqa: E402


def test_every_floor_is_drawn_lowest_last() -> None:
    svg = architecture.architecture()
    floors = [floor for floor, _ in architecture.package_floors()]
    assert floors[0] == "core" and floors[-1] == "cli"
    positions = [svg.index(f'font-weight="bold" fill="#212121" font-family="sans-serif">{f}<')
                 for f in floors]  # fmt: skip
    assert positions == sorted(positions, reverse=True)  # drawn top down: cli first


def test_every_fluids_module_is_in_a_group_and_groups_sit_above_what_they_import() -> None:
    sizes, edges, rank = architecture.fluids_groups()
    layers = architecture._layers()
    modules = [
        m for m in layers.module_files(layers.PACKAGE, "fluids_bench")
        if m.startswith(architecture.FLUIDS + ".")
    ]  # fmt: skip
    assert sum(sizes.values()) == len(modules)
    assert set(architecture.FACES) <= set(sizes)
    for group, targets in edges.items():
        for target in targets:
            assert rank[group] > rank[target], (group, target)
    svg = architecture.architecture()
    for group in sizes:
        assert f">{group}" in svg
