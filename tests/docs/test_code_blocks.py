"""Every fenced code block of the README and the docs runs (docs/development.md, "Code blocks").

```python blocks run as scripts in a fresh interpreter; ```bash blocks run line by line; a block
preceded by ``<!-- test: COMMAND -->`` runs COMMAND instead (the documented shortened variant
of a long command); ``<!-- test: ci -->`` marks the set-up commands, which .ci/run runs
literally. A block that needs an optional piece is preceded by `<!-- needs: NAME ... -->` (above
or below its test marker): `train` (torch, stable-baselines3) marks it `train_extra`; a client
module (`CLIENTS`, e.g. torchrl) marks it `client_extra` and the block runs where the module
imports. Without the piece it skips with the reason (a failure under CI's second phase, which
sets `FLUIDS_BENCH_TRAIN_TESTS=1` / `FLUIDS_BENCH_CLIENT_TESTS=1`), except for clients that live
in their own environment (`OWN_ENVIRONMENT`: always skipped here; their script's results file
is what the docs read). Other languages (text, json, ...) are
output and are not run. Env cards' doctest examples run too.
"""

from __future__ import annotations

import doctest
import importlib.util
import os
import re
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "docs" / "_gen"))
RUN_LANGUAGES = {"python", "bash"}
NOT_RUN = {"text", "json", "yaml", "toml", "console", "output", ""}
# blocks that need the torch extra: skipped "needs the torch extra" where torch is missing
NEEDS_TORCH = re.compile(r"^\s*(import torch|from torch)\b|MLPLearner|CNNLearner", re.MULTILINE)
TIMEOUT_S = 300  # generous: a loaded 2-core CI machine; blocks should take seconds


@dataclass(frozen=True)
class Block:
    path: Path
    line: int
    language: str
    code: str
    marker: str | None  # the <!-- test: ... --> before it
    needs: tuple[str, ...] = ()  # the extras named by <!-- needs: ... --> before it

    @property
    def name(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"


FENCE = re.compile(r"^(\s*)```(\w*)[^\n]*$")
MARKER = re.compile(r"^\s*<!--\s*test:\s*(.*?)\s*-->\s*$")
NEEDS = re.compile(r"^\s*<!--\s*needs:\s*(.*?)\s*-->\s*$")
EXTRAS = {"train": pytest.mark.train_extra}  # the package extras a <!-- needs: ... --> may name
# optional client libraries a <!-- needs: ... --> may name (docs/ecosystem.md)
CLIENTS = {"torch", "torchrl", "stable_baselines3", "d3rlpy", "lerobot"}
# clients whose pins conflict with the suite's: tested in their own venvs
OWN_ENVIRONMENT = {"d3rlpy", "lerobot"}


def blocks_of(path: Path) -> list[Block]:
    lines = path.read_text(encoding="utf-8").splitlines()
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        language, start = m.group(2), i
        j = i + 1
        while j < len(lines) and lines[j].strip() != "```":
            j += 1
        code = textwrap.dedent("\n".join(lines[i + 1 : j]))
        marker, needs, k = None, [], start - 1
        while k >= 0:  # the blank lines and the markers right above the fence
            test, need = MARKER.match(lines[k]), NEEDS.match(lines[k])
            if test and marker is None:
                marker = test.group(1)
            elif need:
                needs += need.group(1).split()
            elif lines[k].strip():
                break
            k -= 1
        out.append(Block(path, start + 1, language, code, marker, tuple(needs)))
        i = j + 1
    return out


def documents() -> list[Path]:
    docs = sorted(p for p in (ROOT / "docs").rglob("*.md") if "_gen" not in p.parts)
    return [ROOT / "README.md", *docs]


ALL_BLOCKS = [b for doc in documents() for b in blocks_of(doc)]
RUN_BLOCKS = [b for b in ALL_BLOCKS if b.language in RUN_LANGUAGES and b.marker != "ci"]


def test_every_block_has_a_known_language():
    unknown = [
        f"{b.name} ({b.language!r})"
        for b in ALL_BLOCKS
        if b.language not in RUN_LANGUAGES | NOT_RUN
    ]
    assert not unknown, f"code blocks in a language the docs test does not know: {unknown}"


def test_every_needs_marker_names_a_known_extra():
    known = set(EXTRAS) | CLIENTS
    unknown = [f"{b.name} ({n!r})" for b in ALL_BLOCKS for n in b.needs if n not in known]
    assert not unknown, f"<!-- needs: ... --> names nothing known {sorted(known)}: {unknown}"


def test_the_set_up_commands_need_no_extra():
    # the README's two commands are what a fresh install runs; they must pass without extras
    assert not [b.name for b in ALL_BLOCKS if b.marker == "ci" and b.needs]


def needs_torch(block: Block) -> bool:
    return bool(NEEDS_TORCH.search(block.code) or NEEDS_TORCH.search(block.marker or ""))


def _param(block: Block):
    marks = [EXTRAS[n] for n in block.needs if n in EXTRAS]
    if needs_torch(block) and pytest.mark.train_extra not in marks:
        marks.append(pytest.mark.train_extra)  # run by .ci/run's second phase, with torch
    if any(n in CLIENTS for n in block.needs):
        marks.append(pytest.mark.client_extra)  # likewise, with the client installed
    return pytest.param(block, marks=marks, id=block.name)


def test_the_set_up_commands_are_what_ci_runs():
    ci = (ROOT / ".ci" / "run").read_text()
    marked = [b for b in ALL_BLOCKS if b.marker == "ci"]
    assert marked, "the README's set-up block is not marked <!-- test: ci -->"
    for block in marked:
        for line in block.code.splitlines():
            if line.strip() and not line.lstrip().startswith("#"):
                assert line.strip() in ci, f"{block.name}: {line!r} is not in .ci/run"


@pytest.fixture
def sandbox(tmp_path):
    (tmp_path / "scripts").symlink_to(ROOT / "scripts")
    env = {
        **os.environ,
        "MPLBACKEND": "Agg",
        "MINARI_DATASETS_PATH": str(tmp_path / "minari"),
        "PYTHONPATH": str(ROOT),
        "SDL_VIDEODRIVER": "dummy",
    }
    return tmp_path, env


def _needs_clients(block: Block) -> None:
    """Skip (or fail, under FLUIDS_BENCH_CLIENT_TESTS=1) a block whose client is missing."""
    for module in block.needs:
        if module not in CLIENTS or importlib.util.find_spec(module) is not None:
            continue
        reason = f"needs the optional client {module} (docs/ecosystem.md says how to install)"
        if module in OWN_ENVIRONMENT or os.environ.get("FLUIDS_BENCH_CLIENT_TESTS") != "1":
            pytest.skip(reason)
        pytest.fail(f"FLUIDS_BENCH_CLIENT_TESTS=1 but this block {reason}")


@pytest.mark.parametrize("block", [_param(b) for b in RUN_BLOCKS])
def test_code_block_runs(block, sandbox):
    folder, env = sandbox
    _needs_clients(block)
    if needs_torch(block):
        from train_extra import require_torch

        require_torch()
    if block.marker is not None:
        cmd = ["bash", "-euo", "pipefail", "-c", block.marker]
    elif block.language == "python":
        script = folder / "block.py"
        script.write_text(block.code)
        cmd = [sys.executable, str(script)]
    else:
        cmd = ["bash", "-euo", "pipefail", "-c", block.code]
    run = subprocess.run(
        cmd, cwd=folder, env=env, capture_output=True, text=True, timeout=TIMEOUT_S, check=False
    )
    assert run.returncode == 0, (
        f"{block.name} failed ({run.returncode}):\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}"
    )


def _card_examples():
    import reference

    out = []
    for f in reference.FAMILIES:
        for env_id in f.ids + f.parallel_ids:
            owner = reference._card_owner(env_id)  # noqa: SLF001
            if owner not in [o for o, _ in out]:
                out.append((owner, env_id))
    return out


def _card_doctest(owner) -> doctest.DocTest:
    # the card fences its example in Markdown; a closing fence would read as expected output
    lines = textwrap.dedent(owner.__doc__ or "").splitlines()
    doc = "\n".join("" if line.strip().startswith("```") else line for line in lines)
    return doctest.DocTestParser().get_doctest(doc, {}, owner.__name__, None, 0)


CARDS_WITH_EXAMPLES = [o for o, _ in _card_examples() if _card_doctest(o).examples]


@pytest.mark.parametrize("owner", CARDS_WITH_EXAMPLES, ids=lambda o: o.__name__)
def test_env_card_examples_run(owner):
    test = _card_doctest(owner)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    runner.run(test, out=lambda s: None)
    assert runner.failures == 0, f"{owner.__name__}'s env card example failed"
