"""Actions and labels at the velocity and control levels, for all worlds of a batch at once.

``FluidsEnv._act`` world by world clips the ego's action, puts it in place of the supervisor's
at its level, and advances the PID loops' memory for the controls it returns.
:func:`act_batch` does the same with array operations over the stepping worlds, operation for
operation the scalar env's (the clip as Python's ``min(max(v, lo), hi)``, signed zeros
included), so each world's controls and memory are bit for bit what its own ``_act`` gives.
:func:`label_batch` is ``FluidsEnv.supervisor_action`` of the worlds whose supervisor just
proposed, read from the batch's rows. The other levels (routes, waypoints) go world by world.
"""

from __future__ import annotations

import numpy as np

from fluids_bench.tasks.fluids import levels
from fluids_bench.tasks.fluids.sim.batch import WorldBatch
from fluids_bench.tasks.fluids.supervisor.batch import (
    PID_MEMORY,
    SupervisorBatch,
)

BATCHED_LEVELS = ("velocity", "control")


def clip(values: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """``min(max(v, lo), hi)`` elementwise, as Python's (which keeps ``v`` on ties)."""
    values = np.where(low > values, low, values)
    return np.where(high < values, high, values)


def act_batch(
    envs: list,
    actions: np.ndarray,
    stepping: np.ndarray,
    bounds: tuple[np.ndarray, np.ndarray],
    worlds: WorldBatch,
    supervisors: SupervisorBatch,
    scratch: dict[str, np.ndarray],
) -> None:
    """Write every stepping world's controls into ``worlds.controls`` and advance its PID
    memory, as ``FluidsEnv._act`` of its clipped action would; ``envs`` act at one of
    :data:`BATCHED_LEVELS`; ``bounds``: the action space's low and high (flat, float64);
    ``scratch``: arrays this function keeps between calls."""
    first = envs[0]
    level, world = first.action_level, first.world
    values = clip(actions.reshape(len(envs), -1).astype(np.float64), *bounds)
    if first.action_scale == "normalized":
        values = levels.to_physical(level, world, values)
    # the ego's action counts while it drives ("all" mode: after arriving it is ignored)
    chosen = stepping & worlds["active"][:, 0]
    proposal = stepping & ~chosen if level == "velocity" else stepping
    controls = worlds.controls
    controls[proposal] = supervisors.proposed[proposal]
    supervisors.commit_proposals(proposal)
    if level == "control":  # DrivingSupervisor.denormalise of the ego's row
        car = world.scene.car
        force = values[:, 1] * np.where(values[:, 1] >= 0, car.max_force, car.max_brake_force)
        ego = np.column_stack([values[:, 0] * car.max_steer, force])
        controls[chosen, 0] = ego[chosen]
        return
    # velocity: the PID toward the supervisor's targets with the ego's replaced (all agents)
    targets = scratch.setdefault("targets", np.empty_like(supervisors.plans["targets"]))
    memory = scratch.setdefault("memory", np.empty_like(supervisors.next_memory))
    np.copyto(targets, supervisors.plans["targets"])
    targets[:, 0] = values[:, 0]
    supervisors.follow(chosen, worlds, targets, controls, memory)
    for k, name in enumerate(PID_MEMORY):  # PIDController.commit of that PID's memory
        supervisors.memory[name][chosen] = memory[chosen, k]


def label_batch(
    envs: list, going: np.ndarray, supervisors: SupervisorBatch, labels: np.ndarray
) -> None:
    """Write into ``labels`` (B, 1) or (B, 2) float32 the label of every world where
    ``going`` (its supervisor proposed in this step, from the batch's rows), as
    ``levels.label`` gives it; the other rows are left alone."""
    first = envs[0]
    level, world = first.action_level, first.world
    if level == "velocity":
        value = supervisors.plans["targets"][going, :1]
        if first.action_scale == "normalized":
            value = levels.to_normalized(level, world, value)
    else:  # DrivingSupervisor.normalise of the ego's proposed controls
        car = world.scene.car
        steer, force = supervisors.proposed[going, 0, 0], supervisors.proposed[going, 0, 1]
        force = force / np.where(force >= 0, car.max_force, car.max_brake_force)
        value = clip(np.column_stack([steer / car.max_steer, force]), -1.0, 1.0)
    labels[going] = value
