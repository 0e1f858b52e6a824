"""scripts/benchmarks/bench_ab.py: the throughput figures it compares are found in nested dicts
and in lists of measurements (named by their env, batch size and agents)."""

from __future__ import annotations

from script_module import load_script


def _module():
    return load_script("benchmarks/bench_ab.py")


def test_rates_reach_into_dicts_and_lists_and_skip_other_numbers():
    result = {
        "steps": 100,
        "S2": {"steps_per_s": 5.0, "seconds": 2.0},
        "batch": [
            {"env": "scalar", "num_envs": 1, "steps_per_cpu_s": 10.0},
            {"env": "vector", "num_envs": 64, "steps_per_cpu_s": 30.0, "vs_scalar": 3.0},
        ],
        "plain": [{"steps_per_s": 7.0}],
    }
    assert _module().rates(result) == {
        "S2/steps_per_s": 5.0,
        "batch[env=scalar,num_envs=1]/steps_per_cpu_s": 10.0,
        "batch[env=vector,num_envs=64]/steps_per_cpu_s": 30.0,
        "plain[0]/steps_per_s": 7.0,
    }
