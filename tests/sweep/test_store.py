"""The result store: durable appends, resume, a partial last line cut off, refused mixes."""

from __future__ import annotations

import pytest

from fluids_bench.sweep.grid import Grid
from fluids_bench.sweep.store import COLUMNS, RESULTS, ResultStore, format_row, load_rows

MANIFEST = {"grid": Grid.default().to_dict(), "episodes": 2, "seed": 0}


def _row(index: int, successes: int = 1) -> dict:
    configuration = Grid.default().configuration(index)
    return {
        "index": index,
        **configuration,
        "episodes": 2,
        "successes": successes,
        "collisions": 2 - successes,
        "timeouts": 0,
        "success_rate": successes / 2,
        "mean_steps": 123.5 + index / 3,
    }


def test_rows_survive_reopening_and_read_back_exactly(tmp_path):
    with ResultStore(tmp_path) as store:
        assert store.open(MANIFEST) == {}
        for index in (5, 0, 7):
            store.append(_row(index))
    with ResultStore(tmp_path) as store:
        rows = store.open(MANIFEST)
        assert sorted(rows) == [0, 5, 7]
        assert rows[5]["mean_steps"] == _row(5)["mean_steps"]  # floats round-trip exactly
        assert rows[5]["lights"] == 0 and rows[5]["cars"] == 2
        store.append(_row(1))
    assert [r["index"] for r in load_rows(tmp_path)] == [0, 1, 5, 7]


def test_a_partial_last_line_is_cut_off_and_rerun(tmp_path):
    with ResultStore(tmp_path) as store:
        store.open(MANIFEST)
        store.append(_row(0))
    path = tmp_path / RESULTS
    with path.open("a") as handle:  # a kill in the middle of writing row 3
        handle.write(format_row(_row(3))[:17])
    assert [r["index"] for r in load_rows(tmp_path)] == [0]  # readers ignore it
    with ResultStore(tmp_path) as store:
        assert sorted(store.open(MANIFEST)) == [0]
        store.append(_row(3))
    lines = path.read_text().splitlines()
    assert lines[0] == ",".join(COLUMNS) and len(lines) == 3
    assert [r["index"] for r in load_rows(tmp_path)] == [0, 3]


def test_a_kill_while_writing_the_header_starts_over(tmp_path):
    tmp_path.joinpath(RESULTS).write_text("index,ca")
    with ResultStore(tmp_path) as store:
        store.open(MANIFEST)  # no manifest yet: a fresh sweep
        store.append(_row(2))
    assert [r["index"] for r in load_rows(tmp_path)] == [2]


def test_another_manifest_is_refused_unless_overwriting(tmp_path):
    with ResultStore(tmp_path) as store:
        store.open(MANIFEST)
        store.append(_row(0))
    other = {**MANIFEST, "episodes": 3}
    with pytest.raises(FileExistsError, match="episodes.*--overwrite"):
        ResultStore(tmp_path).open(other)
    assert [r["index"] for r in load_rows(tmp_path)] == [0]  # untouched
    with ResultStore(tmp_path) as store:
        assert store.open(other, overwrite=True) == {}
    with ResultStore(tmp_path) as store:
        assert store.open(other) == {}


def test_rows_without_a_manifest_are_not_discarded_silently(tmp_path):
    with ResultStore(tmp_path) as store:
        store.open(MANIFEST)
        store.append(_row(0))
    (tmp_path / "manifest.json").unlink()
    with pytest.raises(FileExistsError, match="no manifest"):
        ResultStore(tmp_path).open(MANIFEST)
    with ResultStore(tmp_path) as store:
        assert store.open(MANIFEST, overwrite=True) == {}


def test_two_writers_are_refused(tmp_path):
    with ResultStore(tmp_path) as first:
        first.open(MANIFEST)
        with pytest.raises(FileExistsError, match="another sweep"):
            ResultStore(tmp_path).open(MANIFEST)
    with ResultStore(tmp_path) as again:  # the lock went with the first writer
        again.open(MANIFEST)


def test_corrupt_or_conflicting_rows_are_errors(tmp_path):
    with ResultStore(tmp_path) as store:
        store.open(MANIFEST)
        store.append(_row(0))
    path = tmp_path / RESULTS
    text = path.read_text()
    path.write_text(text + format_row(_row(0, successes=2)))
    with pytest.raises(ValueError, match="recorded twice"):
        ResultStore(tmp_path).open(MANIFEST)
    path.write_text(text + "1,2,3\n")
    with pytest.raises(ValueError, match="cells"):
        ResultStore(tmp_path).open(MANIFEST)
    with pytest.raises(ValueError, match="lacks"):
        format_row({"index": 0})
    with pytest.raises(RuntimeError, match="open"):
        ResultStore(tmp_path).append(_row(1))


@pytest.mark.parametrize("damage", ["truncate", "list", "binary"])
def test_a_damaged_manifest_is_named_with_what_to_do(tmp_path, damage):
    with ResultStore(tmp_path) as store:
        store.open(MANIFEST)
        store.append(_row(0))
    path = tmp_path / "manifest.json"
    text = path.read_bytes()
    path.write_bytes(
        {"truncate": text[: len(text) // 2], "list": b"[1]", "binary": b"\xff\xfe"}[damage]
    )
    with pytest.raises(ValueError, match=r"manifest\.json .*--out folder, or --overwrite"):
        ResultStore(tmp_path).open(MANIFEST)
    with pytest.raises(ValueError, match=r"manifest\.json"):
        ResultStore(tmp_path).read_manifest()
    with ResultStore(tmp_path) as store:  # --overwrite starts the sweep over
        assert store.open(MANIFEST, overwrite=True) == {}
    assert ResultStore(tmp_path).read_manifest() == MANIFEST
