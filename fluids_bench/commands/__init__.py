"""Subcommands of the `fluids-bench` command line (see `fluids_bench.cli`)."""

from __future__ import annotations

import re


def plain_text(doc: str | None) -> str:
    """A Markdown docstring as terminal help: code spans lose their backticks."""
    return re.sub(r"`([^`\n]+)`", r"\1", doc or "")
