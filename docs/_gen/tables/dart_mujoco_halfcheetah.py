"""Renderer of docs/results/dart_mujoco_halfcheetah.json: the layout of dart_mujoco_hopper.json, so the
same table (see dart_mujoco_hopper.py)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

_spec = importlib.util.spec_from_file_location(
    "docs_tables_dart_mujoco_common", Path(__file__).with_name("dart_mujoco_hopper.py")
)
_module = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_module)
render = _module.render
