"""Agent dynamics, integrated for all agents at once (explicit Euler, step `dt` seconds).

Cars follow the kinematic bicycle model (ch. 7):
    x' = v cos(θ + β),  y' = v sin(θ + β),  v' = F / m,  θ' = (v / l_r) sin β,
    β = atan(l_r / (l_f + l_r) · tan ψ)
with steering ψ (rad) and force F (N). Pedestrians follow the point model: they walk in direction
ψ (rad, which becomes their heading) and accelerate at a (m/s²). Speeds are clipped to
[0, max_speed]: neither cars nor pedestrians reverse.

The loop over agents is compiled (numba): a few dozen operations per agent cost less as a
loop than as numpy calls on arrays of tens of elements. Its arithmetic is the array
formulation's, operation for operation (`tests/tasks/fluids/sim/numpy_reference.py`), with the
C library's scalar trigonometric functions.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fluids_bench.core.compiled import kernel


@njit(cache=True, nogil=True, inline="always")
def wrap_angle(angle: float) -> float:  # pragma: no cover (compiled)
    """To [-π, π), as `(angle + π) % 2π − π` (Python's and numpy's floored modulo)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


@kernel
def advance(state, controls, is_car, params, dt, active):  # pragma: no cover (compiled)
    """One step of every `active` agent, in place (the arrays as for `integrate`)."""
    for i in range(state.shape[0]):
        if not active[i]:
            continue
        x, y, th, v = state[i, 0], state[i, 1], state[i, 2], state[i, 3]
        psi, u = controls[i, 0], controls[i, 1]
        if is_car[i]:
            lf, lr = params[i, 1], params[i, 2]
            beta = math.atan(lr / (lf + lr) * math.tan(psi))
            accel = u / params[i, 0]
            heading = th + beta
            new_th = th + v / lr * math.sin(beta) * dt
        else:  # pedestrians walk the way they face
            accel, heading, new_th = u, psi, psi
        state[i, 0] = x + v * math.cos(heading) * dt
        state[i, 1] = y + v * math.sin(heading) * dt
        state[i, 2] = wrap_angle(new_th)
        speed = v + accel * dt
        if speed < 0.0:
            speed = 0.0
        state[i, 3] = min(speed, params[i, 3])


def integrate(
    state: np.ndarray,
    controls: np.ndarray,
    is_car: np.ndarray,
    params: np.ndarray,
    dt: float,
    active: np.ndarray | None = None,
) -> np.ndarray:
    """One step for every agent (or every `active` one; the others keep their state); returns
    the new state array.

    state: (N, 4) [x, y, θ, v]; controls: (N, 2) [ψ, F] for cars, [ψ, a] for pedestrians;
    params: (N, 4) [mass, l_f, l_r, max_speed] (mass and axles unused for pedestrians).
    """
    new = np.array(state, dtype=np.float64)
    active = np.ones(len(new), dtype=bool) if active is None else active
    advance(
        new,
        np.asarray(controls, dtype=np.float64),
        np.asarray(is_car, dtype=bool),
        np.asarray(params, dtype=np.float64),
        float(dt),
        active,
    )
    return new
