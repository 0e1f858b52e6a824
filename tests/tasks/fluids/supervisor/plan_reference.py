"""The velocity planner's tick step by step, through its public methods: the reference the
compiled two-call :meth:`VelocityPlanner.plan` (``plan_kernels.py``) is compared against, and
the tests' hook on the CSP instances it solves."""

from __future__ import annotations

import numpy as np

from fluids_bench.tasks.fluids.supervisor.csp_kernels import plan_choice


def stepwise_plan(planner, world, uncontrolled=None, choose=plan_choice) -> np.ndarray:
    """Every agent's target (m/s) from :meth:`allowed_speed`, :meth:`project`, the domains,
    :meth:`defensive_domains` toward ``uncontrolled``, :meth:`conflicts` and ``choose`` (called
    as :func:`plan_choice`, so a test can record the instances)."""
    planner._bind(world)
    out = np.zeros(world.n)
    agents = world.active.nonzero()[0]
    if not len(agents):
        return out
    targets = planner.allowed_speed(world, agents)[:, None] * planner.fractions[None, :]
    s_proj = planner.project(world, agents, targets)
    allowed, hold = planner._domains_and_hold_lines(world, agents, s_proj, uncontrolled)
    if uncontrolled is not None and uncontrolled[agents].any():
        allowed &= planner.defensive_domains(world, agents, targets, uncontrolled[agents], hold)
    pairs, conflict = planner.conflicts(world, agents, s_proj)
    choice, solved = choose(
        agents, world.s, world.offset, planner._front, world.route,
        world.layout.routes.enter_s, allowed, pairs, conflict,
    )  # fmt: skip
    assert solved
    out[agents] = targets[np.arange(len(agents)), choice]
    return out
