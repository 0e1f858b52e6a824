"""Are the labels DAgger stores on FLUIDS-v4 the labels of the states it stores them with?

A one-off check, printed. Fits a regression tree on one supervisor demonstration (train seed
1000), then drives supervisor and learner episodes (train seeds 7000-7003) through
`fluids_bench.algos.rollout.rollout` with an actor that, at every state, compares the label it
is handed (the one `rollout` stores with that observation) with the label of a supervisor that
re-plans from the car's pose and route alone (`dagger_fluids_v4.replanned_label`). Counts the
states that differ, on and off recovery paths.

    PYTHONPATH=. nice -n 10 python scripts/checks/dagger_label_alignment.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.actors import SUPERVISOR
from fluids_bench.algos.learners.sklearn import PolicySpec, fit_policy
from fluids_bench.algos.rollout import rollout

sys.path.insert(0, str(Path(__file__).resolve().parent))
from dagger_fluids_v4 import replanned_label  # noqa: E402


class Check:
    def __init__(self, env, policy=None) -> None:
        self.inner, self.policy = env.unwrapped, policy
        self.counts = {"on_route": [0, 0], "recovering": [0, 0]}  # [states, labels that differ]

    def __call__(self, observation, label, rng):
        kind = "recovering" if self.inner.world.recovering[0] else "on_route"
        self.counts[kind][0] += 1
        self.counts[kind][1] += not np.array_equal(replanned_label(self.inner), label)
        return label if self.policy is None else self.policy.act(observation)


def main() -> None:
    env = gym.make("FLUIDS-v4")
    demo = rollout(env, SUPERVISOR, 1000)
    tree = fit_policy(PolicySpec(name="tree"), env.action_space, demo.states, demo.labels, 0)
    for name, policy in (("supervisor", None), ("learner", tree)):
        check = Check(env, policy)
        for seed in range(7000, 7004):
            rollout(env, check, seed)
        print(name, {k: {"states": v[0], "differ": v[1]} for k, v in check.counts.items()})


if __name__ == "__main__":
    main()
