"""Importing a script of ``scripts/`` (not a package) in a test: ``load_script(path)``."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


def load_script(path: Path | str, name: str | None = None) -> ModuleType:
    """The module of the script at ``path`` (relative paths are under ``scripts/``), executed
    once per call under ``name`` (default: the file's stem)."""
    path = SCRIPTS / path if not Path(path).is_absolute() else Path(path)
    spec = importlib.util.spec_from_file_location(name or path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
