"""`fluids-bench <command> --help` reads as plain text: no Markdown or reST markup."""

from __future__ import annotations

import argparse
import re

import pytest

from fluids_bench.cli import build_parser

MARKUP = re.compile(r"`|::\n|:(class|data|mod|func|meth|attr):")


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]  # noqa: SLF001
    return {"": parser, **sub.choices}


@pytest.mark.parametrize("name", sorted(_subparsers()))
def test_help_is_plain_text(name):
    text = _subparsers()[name].format_help()
    assert not MARKUP.findall(text), f"fluids-bench {name} --help: {MARKUP.findall(text)}"
