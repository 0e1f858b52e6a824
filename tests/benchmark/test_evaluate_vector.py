"""FLUIDS episodes stepped together on the vector env give the rows of episodes run alone.

Each policy kind that acts on a batch (random, the supervisor, a learner, a predict-only
object, an SB3 model) runs five seeds on `FLUIDS-v4` with four worlds, so worlds are refilled
as episodes end at different steps and the last episodes move into smaller vector envs; every
row must equal `run_episode`'s (the scalar path) exactly. `evaluate` with `batch` gives the
same logs and scorecard as with `batch=1`, and a rerun runs nothing.
"""

from __future__ import annotations

import json

import pytest
from benchmark_policies import FluidsAct, FluidsPredict

from fluids_bench.algos import vector_rollout
from fluids_bench.benchmark import episodes
from fluids_bench.benchmark.evaluator import evaluate
from fluids_bench.benchmark.policies import PolicySource
from fluids_bench.benchmark.suite import SUITE

FLUIDS = SUITE.select(tasks=["fluids"]).tasks[0]
SEEDS = [3_000_000_000 + i for i in range(5)]


def _source(kind: str, tmp_path) -> PolicySource:
    if kind in ("random", "supervisor"):
        return PolicySource(kind, kind, kind)
    if kind == "learner":  # a learner's policy acts with act(obs), stateless
        return PolicySource(kind, "learner", None, FluidsAct())
    if kind == "predict":
        return PolicySource(kind, "object", None, FluidsPredict())
    from train_extra import require_sb3

    sb3 = require_sb3()
    import gymnasium as gym

    model = sb3.PPO("MlpPolicy", gym.make("FLUIDS-v4"), n_steps=16, batch_size=16, seed=0)
    path = tmp_path / "ppo.zip"
    model.save(path)
    return PolicySource(kind, "sb3", str(path))


def _jobs(policy: str, kwargs: dict) -> list[episodes.EpisodeJob]:
    text = episodes.kwargs_json(kwargs)
    return [episodes.EpisodeJob(policy, FLUIDS.name, "test", "FLUIDS-v4", text, s) for s in SEEDS]


@pytest.mark.parametrize(
    ("kind", "kwargs"),
    [
        ("random", {}),  # episodes end by termination, at different steps
        ("supervisor", {}),
        ("learner", {"max_episode_steps": 60}),  # and by the time limit
        ("predict", {"max_episode_steps": 60}),
        pytest.param("sb3", {"max_episode_steps": 60}, marks=pytest.mark.train_extra),
    ],
)
def test_vector_rows_equal_the_scalar_rows(kind, kwargs, tmp_path, monkeypatch):
    source = _source(kind, tmp_path)
    episodes.init_worker({(kind, FLUIDS.name): source})
    jobs = _jobs(kind, kwargs)
    assert episodes.vector_group(jobs[0], FLUIDS) is not None
    shrunk = []
    shrink = vector_rollout._shrink

    def watch(batch, *args):
        smaller = shrink(batch, *args)
        if smaller is not batch:
            shrunk.append(smaller.n)
        return smaller

    monkeypatch.setattr(vector_rollout, "_shrink", watch)
    rows: list[dict] = []
    episodes.run_vector_jobs(jobs, FLUIDS, rows.append, batch=4)
    alone = [episodes.run_episode(job, FLUIDS) for job in jobs]
    assert sorted(rows, key=lambda r: r["seed"]) == alone
    if kind in ("random", "supervisor"):
        assert len({r["length"] for r in alone}) > 1
        assert shrunk and shrunk[-1] == 1  # the last episodes moved to smaller envs
        assert any(r["terminated"] for r in alone)
        assert all("driving_score" in r for r in alone)
    else:
        assert not all(r["terminated"] for r in alone)  # the time limit ended some


def test_an_object_with_act_runs_alone():
    episodes.init_worker({("act", FLUIDS.name): PolicySource("act", "object", None, FluidsAct())})
    assert episodes.vector_group(_jobs("act", {})[0], FLUIDS) is None


def test_evaluate_batched_equals_one_by_one_and_resumes(tmp_path):
    suite = SUITE.select(episodes=2, tasks=["fluids"])  # 4 sets x 2 seeds x 3 policies

    def run(out, batch, workers=1):
        return evaluate(
            "benchmark_policies:fluids_predict", suite, tmp_path / out, progress=False,
            plots=False, batch=batch, name="predict", workers=workers,
        )  # fmt: skip

    def logs(out):
        folder = tmp_path / out / "episodes"
        return {p: sorted((folder / f"{p}.jsonl").read_text().splitlines())
                for p in ("predict", "random", "supervisor")}  # fmt: skip

    def tasks(card):
        return json.dumps(card["tasks"], sort_keys=True)  # (a resumed card's keys: sorted)

    one, batched = run("one", 1), run("batched", 3)
    assert logs("one") == logs("batched") and len(logs("one")["predict"]) == 8
    assert tasks(one) == tasks(batched)
    again = run("batched", 3)  # every row is there: nothing runs
    assert len(logs("batched")["predict"]) == 8 and tasks(again) == tasks(one)
    workers = run("workers", 3, workers=2)  # chunks of up to 3 episodes per worker task
    assert logs("workers") == logs("one") and tasks(workers) == tasks(one)


def test_bad_batch_is_refused(tmp_path):
    with pytest.raises(ValueError, match="batch is 0"):
        evaluate("random", SUITE.select(episodes=1, tasks=["fluids"]), tmp_path, batch=0)


def test_random_return_batched_is_the_sum_one_by_one():
    from fluids_bench.benchmark.policies import random_return

    kwargs, seeds = {"num_cars": 2, "num_pedestrians": 1}, [5, 6, 7, 8]
    alone = random_return("FLUIDS-v0", kwargs, seeds, batch=1)
    assert random_return("FLUIDS-v0", kwargs, seeds, batch=3) == alone
