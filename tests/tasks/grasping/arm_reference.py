"""The arm controller written out in plain Python, operation for operation as the compiled
kernel (:func:`fluids_bench.tasks.grasping.kernels.arm_step_kernel`): the tests compare the two."""

from __future__ import annotations

import math

from fluids_bench.tasks.grasping.sim import (
    JT_ITERATIONS,
    GraspConfig,
    forward,
    inverse,
    jacobian,
    within_limits,
    wrap,
)


def arm_step_reference(cfg: GraspConfig, q, velocity) -> list[float]:
    """Joint angles after one env step of commanded end-effector ``velocity`` (m/s).

    1. Jacobian transpose: ``JT_ITERATIONS`` steps ``Δq = α Jᵀ e`` toward the displaced end
       effector ``p + v dt`` (``e`` the remaining error, ``α`` the optimal step along ``J Jᵀ e``);
       this gives its new position.
    2. The arm's one redundant degree of freedom (the null space of ``J``) sets the gripper's
       heading, resolved exactly by inverse kinematics at that position: the gripper trails
       its motion like a caster, turning toward the direction of motion by the fraction
       ``1 - exp(-distance / caster_length)`` of the error (at most ``turn_rate`` per second),
       and holds its heading when the motion points backwards (more than 120° off).
    3. Joint speeds are scaled down to ``joint_speed``, then angles clipped to ``joint_limits``,
       and the whole step scaled down if the end effector would move faster than ``max_speed``.
    """
    points, heading = forward(cfg, q)
    vx, vy = float(velocity[0]), float(velocity[1])
    speed2 = vx * vx + vy * vy
    dq = [0.0, 0.0, 0.0]
    if speed2 > 1e-12:
        # Jacobian-transpose iterations toward the displaced end effector, each with the step
        # length that minimises the remaining error along J Jᵀ e
        goal_x, goal_y = points[4][0] + vx * cfg.dt, points[4][1] + vy * cfg.dt
        moved = [float(q[0]), float(q[1]), float(q[2])]
        pts = points
        free = [True, True, True]  # joints at a limit drop out of J
        for _ in range(JT_ITERATIONS):
            ex, ey = goal_x - pts[4][0], goal_y - pts[4][1]
            j0, j1 = jacobian(pts)
            jte = [(j0[j] * ex + j1[j] * ey) if free[j] else 0.0 for j in range(3)]
            jx = j0[0] * jte[0] + j0[1] * jte[1] + j0[2] * jte[2]
            jy = j1[0] * jte[0] + j1[1] * jte[1] + j1[2] * jte[2]
            denom = jx * jx + jy * jy
            if denom < 1e-18:
                break
            alpha = (ex * jx + ey * jy) / denom
            for j, (lo, hi) in enumerate(cfg.joint_limits):
                m = moved[j] + alpha * jte[j]
                if m <= lo or m >= hi:
                    free[j] = False
                moved[j] = min(hi, max(lo, m))
            pts, _ = forward(cfg, moved)
        dq = [moved[0] - q[0], moved[1] - q[1], moved[2] - q[2]]
        err = wrap(math.atan2(vy, vx) - heading)
        turn = 0.0
        if abs(err) < math.radians(120.0):
            fraction = 1.0 - math.exp(-math.sqrt(speed2) * cfg.dt / cfg.caster_length)
            cap = cfg.turn_rate * cfg.dt
            turn = max(-cap, min(cap, err * fraction))
        branch = 1.0 if moved[1] >= 0 else -1.0
        exact = inverse(cfg, pts[4][0], pts[4][1], heading + turn, elbow=branch)
        if exact is not None:
            # the same wrist angle branch as before (inverse wraps q3 to [-pi, pi))
            exact[2] = q[2] + wrap(exact[2] - q[2])
            if within_limits(cfg, exact):
                dq = [exact[0] - q[0], exact[1] - q[1], exact[2] - q[2]]
    peak = max(abs(d) for d in dq)
    limit = cfg.joint_speed * cfg.dt
    if peak > limit:
        dq = [d * limit / peak for d in dq]
    out = _clipped(cfg, q, dq)
    # the end effector never outruns max_speed (the iterations and clipping can overshoot)
    reach = cfg.max_speed * cfg.dt
    for _ in range(4):
        end, _ = forward(cfg, out)
        moved_by = math.hypot(end[4][0] - points[4][0], end[4][1] - points[4][1])
        if moved_by <= reach:
            break
        dq = [d * reach / moved_by * 0.999 for d in dq]
        out = _clipped(cfg, q, dq)
    return out


def _clipped(cfg: GraspConfig, q, dq) -> list[float]:
    return [
        min(hi, max(lo, float(a) + d))
        for a, d, (lo, hi) in zip(q, dq, cfg.joint_limits, strict=True)
    ]
