"""The compiled CSP against python-constraint2 (``csp_reference.py``): the same assignment,
not merely a valid one, on planner instances recorded from seeded episodes (FLUIDS-v0, and
FLUIDS-v1 with its defensive and give-way constraints, on three layouts) and on random
instances dense enough that the search backtracks and forward checking reorders domains.
Integer logic on both sides: compared exactly.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from csp_reference import reference_choice, reference_priority

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.tasks.fluids.supervisor import velocity
from fluids_bench.tasks.fluids.supervisor.csp_kernels import choose, plan_choice, priority_order


def _recorded(env_id: str, layout: str, seed: int, steps: int = 600):
    """(priority, allowed, pairs, conflict) of every plan of a noisy supervised episode, with
    the priority order checked against the numpy lexsort, the planner's plan_choice against
    choose() with that order, and the compiled plan against the step-by-step one
    (``plan_stepwise``), on the way."""
    instances = []

    def record(agents, s, offset, front, route, enter_s, allowed, pairs, conflict):
        priority = priority_order(agents, s, offset, front, route, enter_s)
        u = env.unwrapped
        assert priority.tolist() == reference_priority(u.supervisor.planner, u.world, agents)
        instances.append((priority, allowed.copy(), pairs.copy(), conflict.copy()))
        got = plan_choice(agents, s, offset, front, route, enter_s, allowed, pairs, conflict)
        want = choose(priority, allowed, pairs, conflict)
        np.testing.assert_array_equal(got[0], want[0])
        assert got[1] == want[1]
        return got

    compiled_plan = velocity.VelocityPlanner.plan

    def plan_and_record(planner, world, uncontrolled=None):
        """The compiled plan, checked against the step-by-step one, which records."""
        got = compiled_plan(planner, world, uncontrolled)
        np.testing.assert_array_equal(got, planner.plan_stepwise(world, uncontrolled, record))
        return got

    env = gym.make(env_id, layout=layout, num_cars=10, num_pedestrians=5)
    rng = np.random.default_rng(seed)
    mp = pytest.MonkeyPatch()
    mp.setattr(velocity.VelocityPlanner, "plan", plan_and_record)
    try:
        _, info = env.reset(seed=seed)
        for step in range(steps):
            action = info["supervisor_action"] + rng.normal(0.0, 0.3, 2)
            _, _, term, trunc, info = env.step(np.clip(action, -1.0, 1.0).astype(np.float32))
            if term or trunc:
                _, info = env.reset(seed=seed + 1000 + step)
    finally:
        mp.undo()
    return instances


@pytest.mark.parametrize("env_id", ["FLUIDS-v0", "FLUIDS-v1"])
@pytest.mark.parametrize("layout", ["four_way", "t_junction", "roundabout"])
def test_choice_equals_python_constraint_on_recorded_plans(env_id, layout):
    solved = 0
    for priority, allowed, pairs, conflict in _recorded(env_id, layout, 7):
        got, found = choose(priority, allowed, pairs, conflict)
        want = reference_choice(priority.tolist(), allowed, pairs, conflict)
        assert found and want is not None
        np.testing.assert_array_equal(got, want)
        k = allowed.shape[1]
        fastest = k - 1 - np.argmax(allowed[:, ::-1], axis=1)
        solved += int((got != fastest).any())
    assert solved >= 5  # the CSP had to move someone off its fastest candidate


def test_choice_equals_python_constraint_on_random_instances():
    """Dense random constraints: backtracking, forward checking, values hidden and put back
    at the end of their domains, and problems with no solution at all."""
    rng = np.random.default_rng(0)
    none = backtracked = 0
    for _ in range(400):
        n, k = int(rng.integers(2, 8)), 5
        allowed = rng.random((n, k)) < 0.7
        allowed[np.arange(n), rng.integers(0, k, n)] = True  # no empty domain (as in plans)
        ii, jj = np.triu_indices(n, k=1)
        keep = rng.random(len(ii)) < 0.6
        pairs = np.column_stack([ii[keep], jj[keep]]).astype(np.int64)
        conflict = rng.random((len(pairs), k, k)) < rng.uniform(0.2, 0.8)
        priority = rng.permutation(n).astype(np.int64)
        got, found = choose(priority, allowed, pairs, conflict)
        want = reference_choice(priority.tolist(), allowed, pairs, conflict)
        assert found == (want is not None)
        if want is None:
            none += 1
            continue
        np.testing.assert_array_equal(got, want)
        backtracked += int((got != k - 1 - np.argmax(allowed[:, ::-1], axis=1)).sum() > 1)
    assert none > 10 and backtracked > 50
