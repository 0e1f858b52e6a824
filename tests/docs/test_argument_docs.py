"""Every argument table's description column comes from the code: each registered id's
entry point documents every keyword argument in its `__init__`'s `Args:` (the FLUIDS envs'
from `FluidsConfig`'s field docs), and no env card holds a hand-written argument list."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS
from fluids_bench.tasks.fluids.config import field_docs

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "docs" / "_gen"))
import reference  # noqa: E402

ALL_IDS = [*ENV_SPECS, *PARALLEL_ENV_SPECS]


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_every_argument_of_every_id_has_a_description(env_id):
    assert reference.undocumented_arguments(env_id) == []
    # and no description of an argument the entry point does not take
    names = {p.name for p in reference._signature_params(env_id)}  # noqa: SLF001
    assert set(reference.argument_docs(env_id)) <= names


def test_an_undocumented_argument_is_found(monkeypatch):
    docs = reference.argument_docs("DAG-v0")
    monkeypatch.setattr(reference, "argument_docs", lambda env_id: {**docs, "mu": ""})
    assert reference.undocumented_arguments("DAG-v0") == ["mu"]


def _rows(table: str) -> dict[str, list[str]]:
    rows = {}
    for line in table.splitlines()[2:]:
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip().strip("|"))]
        rows[cells[0].strip("`")] = cells
    return rows


@pytest.mark.parametrize("env_id", ["FLUIDS-v1", "FLUIDS-MultiAgent-v1", "GridWorld-v0"])
def test_the_table_shows_the_codes_descriptions(env_id):
    rows = _rows(reference.kwargs_table(env_id))
    assert rows and all(cells[-1] for cells in rows.values()), rows
    if env_id.startswith("FLUIDS"):
        docs = field_docs()
        for name, cells in rows.items():
            if name in docs:
                assert cells[-1] == docs[name].replace("|", "\\|")


def test_env_cards_hold_no_hand_written_argument_list():
    found = []
    for env_id in ALL_IDS:
        body = reference.card_sections(env_id).get("Arguments", "")
        listed = [ln for ln in body.splitlines() if re.match(r"\s*(\||[*-] `)", ln)]
        if listed:
            found.append(f"{env_id}: {listed[0]}")
    assert not found, found
