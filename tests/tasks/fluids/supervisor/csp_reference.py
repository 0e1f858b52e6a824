"""The velocity planner's CSP as python-constraint2 solved it, before
:mod:`fluids_bench.tasks.fluids.supervisor.csp_kernels` replayed its search: the solver with
the planner's variable order, the problem built as the planner built it, and the priority
order as a numpy lexsort. A reference for ``test_csp_kernel.py``.
"""

from __future__ import annotations

import numpy as np
from constraint import FunctionConstraint, OptimizedBacktrackingSolver, Problem

from fluids_bench.tasks.fluids.sim.world import World


class _PrioritySolver(OptimizedBacktrackingSolver):
    """Backtracking with a caller-given variable order (the priority order).

    python-constraint2 has no public way to fix the order in which variables are assigned; its
    ``OptimizedBacktrackingSolver`` asks ``getSortedVariables`` for it, which we override. The
    pin in pyproject.toml (>=2.9, <3) covers the versions this was checked on, and
    ``test_priority_order_is_honoured_by_the_installed_solver`` (test_driving_supervisor.py)
    fails if a release stops consulting the override.
    """

    def __init__(self, order: list[int]) -> None:
        super().__init__()
        self.order = order

    def getSortedVariables(self, domains, vconstraints):  # noqa: N802 (library's name)
        return [v for v in self.order if v in domains]


def reference_choice(
    priority: list[int], allowed: np.ndarray, pairs, conflict
) -> np.ndarray | None:
    """Each agent's candidate as the planner chose it with python-constraint2 (None: no
    solution): the fastest allowed, or the CSP's assignment where a constraint binds there."""
    k = allowed.shape[1]
    choice = k - 1 - np.argmax(allowed[:, ::-1], axis=1)  # fastest allowed
    if not (
        len(pairs)
        and conflict[np.arange(len(pairs)), choice[pairs[:, 0]], choice[pairs[:, 1]]].any()
    ):
        return choice
    problem = Problem(_PrioritySolver(list(priority)))
    for a in np.unique(pairs).tolist():
        problem.addVariable(a, allowed[a].nonzero()[0].tolist())
    for (a, b), table in zip(pairs.tolist(), conflict.tolist(), strict=True):
        problem.addConstraint(FunctionConstraint(lambda x, y, bad=table: not bad[x][y]), [a, b])
    solution = problem.getSolution()
    if solution is None:
        return None
    for a, c in solution.items():
        choice[a] = c
    return choice


def reference_priority(self, world: World, agents: np.ndarray) -> list[int]:
    """Positions in ``agents`` in the order the solver assigns them (right of way first)."""
    enter = world.layout.routes.enter_s[world.route[agents]]
    rs = world.route_s[agents] + self._front[agents]
    inside = rs >= enter
    key_inside = np.where(inside, enter - rs, np.inf)  # furthest past the entry first
    key_out = np.where(inside, -np.inf, enter - rs)  # then nearest to it
    return np.lexsort((agents, key_out, key_inside, ~inside)).tolist()
