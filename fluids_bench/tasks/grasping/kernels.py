"""The arm controller compiled (numba): it runs on every step of the env and of the supervisor's
foresight, where its few hundred scalar operations cost ~40 µs in Python.

The arithmetic is that of the plain-Python reference in `tests/tasks/grasping/arm_reference.py`
(which the tests compare with this kernel), in float64 with no fast-math. `params` is
`fluids_bench.tasks.grasping.sim.GraspConfig.kernel_params`: link lengths l1, l2, l3, the
grasp offset, the joint limits (lo, hi) ×3, joint speed, max speed, turn rate, caster length,
dt and the number of Jacobian-transpose iterations.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

BACKWARDS = math.radians(120.0)  # motion more than this far off the heading: hold the heading


@njit(cache=True, nogil=True)
def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


@njit(cache=True, nogil=True)
def _grasp_centre(p: np.ndarray, q0: float, q1: float, q2: float):
    """Grasp centre, joint points (elbow, wrist) and heading of joint angles q."""
    t1 = q0
    t2 = t1 + q1
    t3 = t2 + q2
    x1, y1 = p[0] * math.cos(t1), p[0] * math.sin(t1)
    x2, y2 = x1 + p[1] * math.cos(t2), y1 + p[1] * math.sin(t2)
    c3, s3 = math.cos(t3), math.sin(t3)
    x3, y3 = x2 + p[2] * c3, y2 + p[2] * s3
    xe, ye = x3 + p[3] * c3, y3 + p[3] * s3
    return xe, ye, x1, y1, x2, y2, t3


@njit(cache=True, nogil=True)
def inverse_kernel(
    p: np.ndarray, x: float, y: float, heading: float, elbow: float, out: np.ndarray
):
    """Inverse kinematics into `out`; False if the wrist point is out of reach."""
    l1, l2, l3 = p[0], p[1], p[2]
    back = l3 + p[3]
    wx, wy = x - back * math.cos(heading), y - back * math.sin(heading)
    d2 = wx * wx + wy * wy
    c2 = (d2 - l1 * l1 - l2 * l2) / (2 * l1 * l2)
    if not -1.0 <= c2 <= 1.0:
        return False
    q2 = math.copysign(math.acos(c2), elbow)
    q1 = math.atan2(wy, wx) - math.atan2(l2 * math.sin(q2), l1 + l2 * math.cos(q2))
    q3 = heading - q1 - q2
    q3 = (q3 + math.pi) % (2 * math.pi) - math.pi
    out[0], out[1], out[2] = q1, q2, q3
    return True


@njit(cache=True, nogil=True)
def _within(p: np.ndarray, q: np.ndarray) -> bool:
    for j in range(3):
        if not p[4 + 2 * j] <= q[j] <= p[5 + 2 * j]:
            return False
    return True


@njit(cache=True, nogil=True)
def _clip_into(p: np.ndarray, q: np.ndarray, dq: np.ndarray, out: np.ndarray) -> None:
    for j in range(3):
        out[j] = min(p[5 + 2 * j], max(p[4 + 2 * j], q[j] + dq[j]))


@njit(cache=True, nogil=True)
def arm_step_kernel(p: np.ndarray, q: np.ndarray, vx: float, vy: float) -> np.ndarray:
    """Joint angles after one step of end-effector velocity (vx, vy); see `sim.arm_step`."""
    joint_speed, max_speed, turn_rate, caster, dt = p[10], p[11], p[12], p[13], p[14]
    iterations = int(p[15])
    xe0, ye0, x1, y1, x2, y2, heading = _grasp_centre(p, q[0], q[1], q[2])
    speed2 = vx * vx + vy * vy
    dq = np.zeros(3)
    if speed2 > 1e-12:
        goal_x, goal_y = xe0 + vx * dt, ye0 + vy * dt
        moved = q.copy()
        free = np.ones(3, dtype=np.bool_)
        xe, ye = xe0, ye0
        jte = np.zeros(3)
        for _ in range(iterations):
            ex, ey = goal_x - xe, goal_y - ye
            # Jacobian columns: z × (p - joint_j), joints at the base, elbow and wrist
            j00, j01, j02 = -ye, -(ye - y1), -(ye - y2)
            j10, j11, j12 = xe, xe - x1, xe - x2
            jte[0] = (j00 * ex + j10 * ey) if free[0] else 0.0
            jte[1] = (j01 * ex + j11 * ey) if free[1] else 0.0
            jte[2] = (j02 * ex + j12 * ey) if free[2] else 0.0
            jx = j00 * jte[0] + j01 * jte[1] + j02 * jte[2]
            jy = j10 * jte[0] + j11 * jte[1] + j12 * jte[2]
            denom = jx * jx + jy * jy
            if denom < 1e-18:
                break
            alpha = (ex * jx + ey * jy) / denom
            for j in range(3):
                lo, hi = p[4 + 2 * j], p[5 + 2 * j]
                m = moved[j] + alpha * jte[j]
                if m <= lo or m >= hi:
                    free[j] = False
                moved[j] = min(hi, max(lo, m))
            xe, ye, x1, y1, x2, y2, _ = _grasp_centre(p, moved[0], moved[1], moved[2])
        for j in range(3):
            dq[j] = moved[j] - q[j]
        err = _wrap(math.atan2(vy, vx) - heading)
        turn = 0.0
        if abs(err) < BACKWARDS:
            fraction = 1.0 - math.exp(-math.sqrt(speed2) * dt / caster)
            cap = turn_rate * dt
            turn = max(-cap, min(cap, err * fraction))
        branch = 1.0 if moved[1] >= 0 else -1.0
        exact = np.zeros(3)
        if inverse_kernel(p, xe, ye, heading + turn, branch, exact):
            exact[2] = q[2] + _wrap(exact[2] - q[2])  # keep the wrist's winding
            if _within(p, exact):
                for j in range(3):
                    dq[j] = exact[j] - q[j]
    peak = max(abs(dq[0]), max(abs(dq[1]), abs(dq[2])))
    limit = joint_speed * dt
    if peak > limit:
        for j in range(3):
            dq[j] = dq[j] * limit / peak
    out = np.zeros(3)
    _clip_into(p, q, dq, out)
    # the end effector never outruns max_speed (iterations and clipping can overshoot)
    reach = max_speed * dt
    for _ in range(4):
        xe, ye, _, _, _, _, _ = _grasp_centre(p, out[0], out[1], out[2])
        moved_by = math.hypot(xe - xe0, ye - ye0)
        if moved_by <= reach:
            break
        for j in range(3):
            dq[j] = dq[j] * reach / moved_by * 0.999
        _clip_into(p, q, dq, out)
    return out
