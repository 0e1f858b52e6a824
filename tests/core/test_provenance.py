"""Provenance records relative paths: a results file's command holds no machine's folders."""

from __future__ import annotations

import os
import sys

from fluids_bench.core import provenance


def test_absolute_paths_are_shown_relative_to_the_working_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    args = ["--out", str(tmp_path / "runs" / "a"), f"--work={tmp_path / 'w'}", "--seeds", "0"]
    assert provenance.relative_paths(args) == ["--out", "runs/a", "--work=w", "--seeds", "0"]
    outside = provenance.relative_paths([os.path.dirname(tmp_path)])[0]
    assert not os.path.isabs(outside) and outside == ".."


def test_the_command_line_records_relative_paths(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    script = "scripts/reproductions/x.py"
    monkeypatch.setattr(sys, "argv", [f"/somewhere/{script}", "--out", str(tmp_path / "o.json")])
    assert provenance.command_line() == f"python {script} --out o.json"
