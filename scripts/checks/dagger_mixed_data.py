"""Does DAgger's on-policy data hurt a BC tree on FLUIDS-v4, and do its recovery-path labels?

A one-off check, printed (no results file). Collects 10 supervisor demonstrations (seeds
1000-1009) and a DAgger run of a regression tree from the first of them (12 learner rollouts on
seeds 2000-2011, refit after each), recording at every learner state whether the ego is on a
recovery path and the label of a supervisor that re-plans from the car's pose and route alone.
Then fits trees (and k-nearest-neighbours) on: the 10 demonstrations; those plus DAgger's
learner states with their labels; the same with the re-planned labels; the same without the
recovery-path states; and drives each on seeds 5000-5011 (success, driving score, length).

    PYTHONPATH=. nice -n 10 python scripts/checks/dagger_mixed_data.py
"""

import copy
import time

import gymnasium as gym
import numpy as np

from fluids_bench.algos.actors import SUPERVISOR, LearnerActor
from fluids_bench.algos.learners.sklearn import PolicySpec, fit_policy
from fluids_bench.algos.rollout import rollout
from fluids_bench.tasks.fluids.core import labels
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor


def route_label(inner):
    w = copy.deepcopy(inner.world)
    rs = float(w.s[0] + w.offset[0])
    w.follow_route(0, int(w.route[0]))
    w.s[0] = rs
    w.offset[0] = 0.0
    w.recovering[0] = False
    w._update_progress()
    sup = DrivingSupervisor(w, inner.supervisor_config)
    sup.prepare(w)
    return labels.label(sup, w, inner.action_level, 0, inner.action_scale)


class Rec:
    def __init__(self, inner, policy):
        self.inner, self.policy, self.rows = inner, policy, []

    def __call__(self, obs, label, rng):
        w = self.inner.world
        self.rows.append((bool(w.recovering[0]), route_label(self.inner)))
        return label if self.policy is None else self.policy.act(obs)


env = gym.make("FLUIDS-v4")
inner = env.unwrapped
t0 = time.time()
demos = [rollout(env, SUPERVISOR, 1000 + i) for i in range(10)]
bo = np.concatenate([t.states for t in demos])
bl = np.concatenate([t.labels for t in demos])
# DAgger from 1 demo (the first), 12 iterations, keeping flags and fresh labels
O, L, R, F = (  # noqa: E741  (observations, labels, recovering, re-planned labels)
    [demos[0].states],
    [demos[0].labels],
    [np.zeros(len(demos[0]), bool)],
    [demos[0].labels],
)
pol = fit_policy(PolicySpec(name="tree"), env.action_space, O[0], L[0], 0)
for it in range(12):
    a = Rec(inner, pol)
    t = rollout(env, a, 2000 + it)
    O.append(t.states)
    L.append(t.labels)
    R.append(np.array([r for r, _ in a.rows]))
    F.append(np.array([f for _, f in a.rows]))
    pol = fit_policy(
        PolicySpec(name="tree"), env.action_space, np.concatenate(O), np.concatenate(L), 0
    )
print("collected", round(time.time() - t0), flush=True)
on = slice(1, None)
Oo, Lo, Ro, Fo = (np.concatenate(x[on]) for x in (O, L, R, F))
print(
    "on-policy states",
    len(Oo),
    "recovering",
    Ro.sum(),
    "fresh differs >0.5m",
    int((np.abs(Fo - Lo).max(1) * 50 > 0.5).sum()),
    flush=True,
)
sets = {
    "bc10": (bo, bl),
    "bc10+on": (np.concatenate([bo, Oo]), np.concatenate([bl, Lo])),
    "bc10+on(fresh labels)": (np.concatenate([bo, Oo]), np.concatenate([bl, Fo])),
    "bc10+on(no recovering)": (np.concatenate([bo, Oo[~Ro]]), np.concatenate([bl, Lo[~Ro]])),
}
seeds = [5000 + i for i in range(12)]
for fam in ("tree", "knn"):
    for name, (X, Y) in sets.items():
        p = fit_policy(PolicySpec(name=fam), env.action_space, X, Y, 0)
        res = [rollout(env, LearnerActor(p), s) for s in seeds]
        succ = np.mean([bool(t.infos[-1].get("is_success")) for t in res])
        ds = np.mean([t.infos[-1]["driving_score"] for t in res])
        print(
            f"{fam:5s} {name:26s} n={len(X):5d} success={succ:.2f} ds={ds:.2f} len={np.mean([len(t) for t in res]):.0f}",
            flush=True,
        )
