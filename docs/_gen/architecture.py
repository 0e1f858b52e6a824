"""The Development page's architecture picture, drawn at build time from the package's imports.

`architecture()` returns an inline SVG of two panels: the package's floors (what each floor
holds, lowest at the bottom) and FLUIDS inside its task folder, its module groups ranked by
their imports (a group sits above every group it imports; the faces, the scalar, vector and
multi-agent envs, are coloured). The import graph is `scripts/checks/import_layers.py`'s, the
one the layering test checks, so the picture cannot drift from the code.
"""

from __future__ import annotations

import html
import importlib.util
from functools import lru_cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FLUIDS = "fluids_bench.tasks.fluids"
SPLIT_FOLDERS = ("sim.sensors",)  # a sub-folder of sim/ drawn as a group of its own
BOX_H, ROW_GAP, CHAR_W = 30, 26, 7.2
FACES = ("env", "vector", "multi_agent")  # the scalar, vector and multi-agent envs
FACE, INNER, FLOOR, EDGE, TEXT = "#c5e1a5", "#e3f2fd", "#eceff1", "#90a4ae", "#212121"


@lru_cache(maxsize=1)
def _layers():
    path = ROOT / "scripts" / "checks" / "import_layers.py"
    spec = importlib.util.spec_from_file_location("import_layers", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def package_floors() -> list[tuple[str, list[str]]]:
    """`(floor, its folders and modules)` for every floor, lowest first."""
    layers = _layers()
    members: dict[str, set[str]] = {floor: set() for floor in layers.FLOORS}
    for module in layers.module_files(layers.PACKAGE, "fluids_bench"):
        parts = module.split(".")[1:]
        if not parts:
            continue
        floor = layers.floor_of(module, "fluids_bench")[1]
        floor = "tasks" if floor.startswith("tasks") else floor
        if parts[0] in ("tasks", "core", "algos", "data", "sweep", "benchmark", "human"):
            if len(parts) > 1:
                members[floor].add(parts[1])
        elif parts[0] == "commands" and len(parts) > 1:
            members[floor].add(parts[1])
    return [(floor, sorted(members[floor])) for floor in layers.FLOORS]


def _group(module: str) -> str | None:
    """The FLUIDS group of a module: a sub-folder (sim/sensors, sim, supervisor,
    vector) or a top-level module; None for the task's `__init__`."""
    rest = module[len(FLUIDS) + 1 :] if module.startswith(FLUIDS + ".") else ""
    if not rest:
        return None
    for folder in SPLIT_FOLDERS:
        if rest == folder or rest.startswith(folder + "."):
            return folder.replace(".", "/")
    head = rest.split(".")[0]
    return head


def fluids_groups() -> tuple[dict[str, int], dict[str, set[str]], dict[str, int]]:
    """`(modules per group, group -> groups it imports, rank per group)`: rank 0 imports no
    other group of the task; a group's rank is one more than the highest rank it imports."""
    layers = _layers()
    graph = layers.import_graph(layers.PACKAGE, "fluids_bench")
    sizes: dict[str, int] = {}
    edges: dict[str, set[str]] = {}
    for module, targets in graph.items():
        group = _group(module)
        if group is None:
            continue
        sizes[group] = sizes.get(group, 0) + 1
        edges.setdefault(group, set())
        for target in targets:
            other = _group(target)
            if other is not None and other != group:
                edges[group].add(other)
    rank: dict[str, int] = {}

    def depth(group: str, seen: tuple[str, ...] = ()) -> int:
        if group not in rank:
            if group in seen:  # a cycle between groups: the layering test reports it
                return 0
            below = [depth(g, (*seen, group)) for g in edges.get(group, ())]
            rank[group] = 1 + max(below) if below else 0
        return rank[group]

    for group in sizes:
        depth(group)
    return sizes, edges, rank


def _text(x: float, y: float, text: str, size: int = 13, weight: str = "normal") -> str:
    return (
        f'<text x="{x:.0f}" y="{y:.0f}" font-size="{size}" font-weight="{weight}" '
        f'fill="{TEXT}" font-family="sans-serif">{html.escape(text)}</text>'
    )


def _floors_panel(x0: float, width: float) -> tuple[list[str], float]:
    out = [_text(x0, 20, "The package's floors (an arrow may only point down)", 14, "bold")]
    floors = package_floors()
    y = 34
    for floor, members in reversed(floors):
        line = ", ".join(members) if members else ""
        lines = []
        while line:  # wrap at the band's width
            cut = int((width - 120) / CHAR_W)
            if len(line) <= cut:
                lines.append(line)
                break
            at = line.rfind(", ", 0, cut) + 1 or cut
            lines.append(line[:at].strip())
            line = line[at:].strip()
        height = max(BOX_H, 10 + 17 * max(1, len(lines)))
        out.append(
            f'<rect x="{x0}" y="{y}" width="{width}" height="{height}" rx="4" fill="{FLOOR}" '
            f'stroke="{EDGE}"/>'
        )
        out.append(_text(x0 + 8, y + 20, floor, 13, "bold"))
        for i, text in enumerate(lines):
            out.append(_text(x0 + 112, y + 20 + 17 * i, text, 12))
        y += height + 4
    return out, y


def _fluids_panel(x0: float, width: float) -> tuple[list[str], float]:
    sizes, edges, rank = fluids_groups()
    top = max(rank.values())
    rows = [sorted(g for g in sizes if rank[g] == r) for r in range(top, -1, -1)]
    out = [
        _text(x0, 20, "FLUIDS (tasks/fluids): each group above the groups it imports", 14, "bold")
    ]
    where: dict[str, tuple[float, float, float]] = {}
    y = 40
    for row in rows:
        labels = [f"{g} ({sizes[g]})" if sizes[g] > 1 else g for g in row]
        widths = [CHAR_W * len(label) + 16 for label in labels]
        gap = max(8.0, (width - sum(widths)) / (len(row) + 1))
        x = x0 + gap
        for group, label, w in zip(row, labels, widths, strict=True):
            where[group] = (x, y, w)
            fill = FACE if group in FACES else INNER
            out.append(
                f'<rect x="{x:.0f}" y="{y}" width="{w:.0f}" height="{BOX_H}" rx="4" '
                f'fill="{fill}" stroke="{EDGE}"/>'
            )
            out.append(_text(x + 8, y + 20, label, 13))
            x += w + gap
        y += BOX_H + ROW_GAP
    lines = []
    for group, targets in edges.items():
        gx, gy, gw = where[group]
        for target in targets:
            tx, ty, tw = where[target]
            lines.append(
                f'<line x1="{gx + gw / 2:.0f}" y1="{gy + BOX_H}" x2="{tx + tw / 2:.0f}" '
                f'y2="{ty}" stroke="{EDGE}" stroke-width="1" marker-end="url(#arrow)"/>'
            )
    legend_y = y + 4
    legend = [
        f'<rect x="{x0}" y="{legend_y}" width="14" height="14" fill="{FACE}" stroke="{EDGE}"/>',
        _text(x0 + 20, legend_y + 12, "a face: the scalar (env), vector and multi-agent envs", 12),
        f'<rect x="{x0}" y="{legend_y + 20}" width="14" height="14" fill="{INNER}" '
        f'stroke="{EDGE}"/>',
        _text(x0 + 20, legend_y + 32, "(n): modules in a folder; arrows: imports", 12),
    ]
    return lines + out + legend, legend_y + 40


def architecture() -> str:
    """The picture, as an inline SVG block for a Markdown page."""
    left, left_h = _floors_panel(0, 430)
    right, right_h = _fluids_panel(450, 560)
    height = max(left_h, right_h) + 10
    marker = (
        '<defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="6" '
        f'markerHeight="6" orient="auto"><path d="M0,0 L10,5 L0,10 z" fill="{EDGE}"/></marker>'
        "</defs>"
    )
    body = "".join([marker, *left, *right])
    return (
        f'<svg class="architecture" viewBox="0 0 1010 {height:.0f}" width="100%" '
        f'role="img" aria-label="The package floors and FLUIDS module groups" '
        f'xmlns="http://www.w3.org/2000/svg" style="background:#ffffff;width:100%;height:auto;max-width:1010px">{body}</svg>'
    )


if __name__ == "__main__":
    print(architecture())
