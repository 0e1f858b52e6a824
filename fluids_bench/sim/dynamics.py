"""Agent dynamics, integrated for all agents at once (explicit Euler, step ``dt`` seconds).

Cars follow the kinematic bicycle model (ch. 7):
    x' = v cos(θ + β),  y' = v sin(θ + β),  v' = F / m,  θ' = (v / l_r) sin β,
    β = atan(l_r / (l_f + l_r) · tan ψ)
with steering ψ (rad) and force F (N). Pedestrians follow the point model: they walk in direction
ψ (rad, which becomes their heading) and accelerate at a (m/s²). Speeds are clipped to
[0, max_speed]: neither cars nor pedestrians reverse.
"""

from __future__ import annotations

import numpy as np


def integrate(state: np.ndarray, controls: np.ndarray, is_car: np.ndarray, params: np.ndarray,
              dt: float) -> np.ndarray:
    """One step for every agent; returns the new state array.

    state: (N, 4) [x, y, θ, v]; controls: (N, 2) [ψ, F] for cars, [ψ, a] for pedestrians;
    params: (N, 4) [mass, l_f, l_r, max_speed] (mass and axles unused for pedestrians).
    """
    x, y, th, v = state.T
    psi, u = controls.T
    mass, lf, lr, vmax = params.T
    beta = np.arctan(lr / (lf + lr) * np.tan(psi))
    accel = np.where(is_car, u / mass, u)
    heading = np.where(is_car, th + beta, psi)
    new = np.empty_like(state)
    new[:, 0] = x + v * np.cos(heading) * dt
    new[:, 1] = y + v * np.sin(heading) * dt
    new[:, 2] = np.where(is_car, th + v / lr * np.sin(beta) * dt, psi)
    new[:, 2] = (new[:, 2] + np.pi) % (2 * np.pi) - np.pi
    new[:, 3] = np.minimum(np.maximum(v + accel * dt, 0.0), vmax)
    return new
