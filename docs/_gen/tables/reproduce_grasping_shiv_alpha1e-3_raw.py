"""Renderer of docs/results/reproduce_grasping_shiv_alpha1e-3_raw.json (a Fig. 6.4 ablation): the layout
of reproduce_grasping_shiv.json, so the same table (see reproduce_grasping_shiv.py)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

_spec = importlib.util.spec_from_file_location(
    "docs_tables_reproduce_grasping_shiv_common",
    Path(__file__).with_name("reproduce_grasping_shiv.py"),
)
_module = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_module)
render = _module.render
