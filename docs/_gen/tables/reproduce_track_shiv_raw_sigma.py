"""Renderer of docs/results/reproduce_track_shiv_raw_sigma.json (the ablation of Table 6.1 with
the source's sigma used raw): reproduce_track_shiv.py's table61 part."""

from __future__ import annotations

import importlib.util
from pathlib import Path

_spec = importlib.util.spec_from_file_location(
    "docs_tables_reproduce_track_shiv_common", Path(__file__).with_name("reproduce_track_shiv.py")
)
_module = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_module)


def render(data: dict, **options) -> str:
    return _module.render(data, part="table61")
