"""Every id list of the docs (home and Tasks galleries, family pages, Registration, the README's
task table, which id to use) comes from the registry, so a new id appears by itself."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "docs" / "_gen"))
import reference  # noqa: E402

ALL_IDS = [*ENV_SPECS, *PARALLEL_ENV_SPECS]


def _ids_in(text: str) -> set[str]:
    return {i for i in ALL_IDS if re.search(rf"`{re.escape(i)}`", text)}


def test_every_registered_id_has_exactly_one_family():
    owners = {env_id: reference.family_of(env_id).slug for env_id in ALL_IDS}
    assert sorted(owners) == sorted(ALL_IDS)


@pytest.mark.parametrize(
    "render", [reference.gallery, reference.readme_tasks_table, reference.registry_table]
)
def test_the_id_tables_name_every_registered_id(render):
    assert _ids_in(render()) == set(ALL_IDS)


def test_family_ids_are_newest_first():
    assert reference.family("fluids").ids[:2] == ("FLUIDS-v4", "FLUIDS-Sensitivity-v4")
    assert reference.family("fluids-multi-agent").parallel_ids[0] == "FLUIDS-MultiAgent-v4"


def test_a_newly_registered_id_appears_in_every_list_by_itself(monkeypatch):
    entry, steps, kwargs = ENV_SPECS["FLUIDS-v3"]
    monkeypatch.setitem(ENV_SPECS, "FLUIDS-v99", (entry, steps, kwargs))
    assert reference.family("fluids").ids[0] == "FLUIDS-v99"
    for render in (reference.gallery, reference.readme_tasks_table, reference.registry_table):
        assert "`FLUIDS-v99`" in render()
    assert "`FLUIDS-v99`" in reference.id_guide()  # the newest version of FLUIDS


def test_an_id_of_no_family_stops_the_build(monkeypatch):
    monkeypatch.setitem(ENV_SPECS, "Mystery-v0", ("somewhere.else:MysteryEnv", 10, {}))
    with pytest.raises(ValueError, match="Mystery-v0 .* belongs to 0 families"):
        reference.gallery()


def test_the_readme_task_table_is_the_generated_one():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert reference.readme_tasks_table() in readme, (
        "README's task table differs from the registry: paste `python docs/_gen/reference.py "
        "--readme` into it"
    )


def test_the_id_guide_names_only_registered_ids(monkeypatch):
    assert _ids_in(reference.id_guide()) >= {"FLUIDS-v3", "FLUIDS-v1", "FLUIDS-v0"}
    bad = (("do something", ("FLUIDS-v77",), "tasks/fluids.md"),)
    monkeypatch.setattr(reference, "ID_USES", bad)
    with pytest.raises(ValueError, match="FLUIDS-v77"):
        reference.id_guide()


def test_nav_names_carry_no_version_that_goes_stale():
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8").split("nav:", 1)[1]
    assert not re.findall(r"^\s*- [^:]*\(v\d[^:]*:", nav, flags=re.M)
