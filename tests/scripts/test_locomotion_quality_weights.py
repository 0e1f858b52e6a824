"""scripts/quality/locomotion_supervisor_quality.py --weights: a candidate policy is measured by
the repo's own script, and its records never mix with the shipped policy's."""

from __future__ import annotations

import json

import numpy as np
import pytest
from script_module import load_script

from fluids_bench.tasks.locomotion.policy import MLPPolicy, sha256_of
from fluids_bench.tasks.locomotion.supervisors import WEIGHTS_DIR


def _module():
    return load_script("quality/locomotion_supervisor_quality.py")


def test_a_candidate_is_measured_apart_from_the_shipped_policy(tmp_path):
    shipped = MLPPolicy.from_bytes((WEIGHTS_DIR / "hopper.npz").read_bytes())
    # a different policy: the shipped one with its output layer halved
    shipped.weights[-1] *= 0.5
    candidate = tmp_path / "hopper_candidate.npz"
    candidate.write_bytes(shipped.to_bytes())
    out, script = tmp_path / "q.jsonl", _module()
    common = ["--env", "Hopper-IL-v0", "--episodes", "1", "--steps", "40", "--out", str(out)]
    assert script.main([*common, "--results", str(tmp_path / "shipped.json")]) == 0
    assert (
        script.main(
            [*common, "--weights", f"Hopper={candidate}", "--results", str(tmp_path / "cand.json")]
        )
        == 0
    )
    records = [json.loads(line) for line in out.read_text().splitlines()]
    assert [r["weights_sha256"] for r in records] == [None, sha256_of(candidate)]
    assert records[0]["return"] != records[1]["return"]
    report = json.loads((tmp_path / "cand.json").read_text())
    assert report["weights"]["Hopper"]["sha256"] == sha256_of(candidate)
    assert report["rows"][0]["mean_return"] == pytest.approx(records[1]["return"], abs=0.1)
    assert np.isfinite(report["rows"][0]["mean_return"])


@pytest.mark.parametrize("item", ["Hopper", "Ant=x.npz", "Hopper=/no/such/file.npz"])
def test_a_bad_weights_item_is_refused_by_name(item, tmp_path, capsys):
    with pytest.raises(SystemExit):
        _module().main(["--env", "Hopper-IL-v0", "--weights", item, "--out", str(tmp_path / "q")])
    assert f"--weights {item!r}" in capsys.readouterr().err


def test_a_candidate_never_writes_the_docs_table(tmp_path, capsys):
    weights = WEIGHTS_DIR / "hopper.npz"
    with pytest.raises(SystemExit):
        _module().main(["--env", "Hopper-IL-v0", "--weights", f"Hopper={weights}"])
    assert "name its own --results" in capsys.readouterr().err
