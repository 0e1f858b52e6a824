"""The citation: the same BibTeX in the README and on the home page, naming the package's
current version, and saying plainly that there is no public repository URL (none is invented)."""

from __future__ import annotations

import re
from pathlib import Path

import fluids_bench

ROOT = Path(__file__).resolve().parents[2]


def _bibtex(path: Path) -> str:
    text = path.read_text(encoding="utf-8")
    (entry,) = re.findall(r"```text\n(@software\{.*?\n\})\n```", text, flags=re.S)
    return entry


def test_readme_and_home_page_cite_the_same_entry_at_the_current_version():
    readme, home = _bibtex(ROOT / "README.md"), _bibtex(ROOT / "docs" / "index.md")
    assert readme == home
    assert f"version = {{{fluids_bench.__version__}}}" in readme


def test_no_repository_url_is_invented():
    assert "No public repository URL" in _bibtex(ROOT / "README.md")
    assert "url" not in _bibtex(ROOT / "README.md").lower().replace("no public repository url", "")
    assert "repo_url" not in (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
