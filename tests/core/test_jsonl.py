from fluids_bench.core.jsonl import read_rows


def test_read_rows_skips_a_torn_last_line(tmp_path):
    log = tmp_path / "run.jsonl"
    assert read_rows(log) == [] and read_rows(None) == []
    log.write_text('{"a": 1}\n{"a": 2}\n{"a": 3, "b"')  # killed mid-write
    assert read_rows(log) == [{"a": 1}, {"a": 2}]
