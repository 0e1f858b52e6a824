"""The grasping supervisor: corridor choice with foresight, waypoints, and a saturated P-controller.

Three levels, as the FLUIDS supervisor:

- **behaviour** (:func:`rank_corridors`, :meth:`GraspSupervisor.plan`): which approach corridor to
  the target. Candidates are gripper headings fanned around the bearing from the arm's base to
  the target; each corridor is the strip the open jaws sweep from a lead-in point to the target.
  They are ranked by how deep obstacles reach into the strip (reachability checked by inverse
  kinematics), then the best few are *simulated* on worlds rebuilt from the current state
  (:func:`foresee`) with the levels below in the loop, and the one with the lowest source cost
  (knocked off + 10 × not grasped, ties to fewer steps and less disturbance) is kept;
- **trajectory** (:func:`corridor_action`): end-effector waypoints along the corridor: retract out
  of the clutter when off the corridor, transit to the lead-in point (around the cluster when the
  straight path would cross it), approach along the corridor (the gripper turns toward the
  motion), align, advance to the target, close;
- **control**: a saturated P-controller to the current waypoint, in the action's units
  (end-effector velocity normalised by ``max_speed``, clipped to [-1, 1]), and the grip command.

The plan is cached, so labels between replans cost one waypoint evaluation. The waypoint phase is
recomputed from the state every call, so the label for a state a learner drove to is what the
supervisor would do from there; the plan itself is replaced when the state leaves it: the target
moved, an obstacle entered the corridor, or the plan ran long past its predicted length.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from fluids_bench.tasks.grasping.sim import (
    N_OBJECTS,
    TARGET,
    GraspConfig,
    GraspWorld,
    WorldState,
    inverse,
    wrap,
)

LEAD_IN = 0.20  # m: lead-in point before the target, outside the clutter
STAND_OFF = 0.10  # m: where the final advance starts
CLUTTER = 0.16  # m: around the target, transit goes around and off-corridor motion retracts
ADVANCE_SPEED = 0.5  # fraction of max speed in the final advance
GAIN = 8.0  # 1/s: P-gain of the end-effector controller
FINGER_CLEAR = 0.065  # m: closer than this, the fingertips reach the target
CREEP = 0.35  # normalised speed of the align creep (above the caster's dead band)
LATERAL_GAIN = 10.0  # 1/m: normalised lateral correction while aligning
ALIGNED = math.radians(12.0)
ALIGNABLE = math.radians(30.0)  # larger errors at the stand-off: back out and come again
LIMIT_MARGIN = 0.1  # rad
REPLAN_MOVE = 0.02  # m: the target moved this far since the plan
REPLAN_SLACK = 12
REPLAN_INTRUSION = 0.1  # intrusion score (1 = an obstacle caught in the jaws' path)  # steps beyond the predicted length before a replan


@dataclass(frozen=True)
class Corridor:
    """A behaviour: approach the target with the gripper heading ``heading`` (rad)."""

    heading: float
    intrusion: float  # how deep obstacles reach into the strip (m, summed), at ranking time


@dataclass
class Plan:
    corridor: Corridor
    target_xy: tuple[float, float]  # target centre when planned
    start_step: int
    predicted_steps: int
    predicted_cost: float


def _seg_dist(px, py, ax, ay, bx, by) -> float:
    dx, dy = bx - ax, by - ay
    t = ((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)
    t = min(1.0, max(0.0, t))
    return math.hypot(px - ax - t * dx, py - ay - t * dy)


def intrusion(cfg: GraspConfig, st: WorldState, heading: float) -> float:
    """How badly obstacles obstruct the corridor: 1 per obstacle whose centre lies in the jaws'
    path (it would be caught between the fingers and shoved into the target), plus the depth
    (m, ×10) by which the others' bounding circles reach into the strip the fingers sweep."""
    tx, ty = st.poses[TARGET, 0], st.poses[TARGET, 1]
    c, s = math.cos(heading), math.sin(heading)
    ax, ay = tx - LEAD_IN * c, ty - LEAD_IN * s
    bx, by = tx + 0.03 * c, ty + 0.03 * s
    jaws = cfg.gap_open / 2
    half = jaws + 2 * cfg.finger_radius + 0.005
    total = 0.0
    for i in range(N_OBJECTS):
        if i == TARGET or not st.on_table[i]:
            continue
        r = math.hypot(*st.sizes[i]) / 2
        d = _seg_dist(st.poses[i, 0], st.poses[i, 1], ax, ay, bx, by)
        if d < jaws:
            total += 1.0
        else:
            total += 10.0 * max(0.0, half + r - d)
    return total


def reachable(cfg: GraspConfig, x: float, y: float, heading: float, elbow: float) -> bool:
    """Inverse kinematics on the arm's elbow branch lands inside the joint limits, with
    :data:`LIMIT_MARGIN` to spare (the gripper must still turn on the way)."""
    q = inverse(cfg, x, y, heading, elbow)
    return q is not None and all(
        lo + LIMIT_MARGIN <= a <= hi - LIMIT_MARGIN
        for a, (lo, hi) in zip(q, cfg.joint_limits, strict=True)
    )


def rank_corridors(cfg: GraspConfig, st: WorldState, fan_deg: tuple[float, ...]) -> list[Corridor]:
    """Reachable corridors, least obstructed first (ties: closest to the radial approach)."""
    tx, ty = st.poses[TARGET, 0], st.poses[TARGET, 1]
    bearing = math.atan2(ty, tx)
    elbow = 1.0 if st.q[1] >= 0 else -1.0  # the arm stays on its elbow branch
    out = []
    for delta in fan_deg:
        h = bearing + math.radians(delta)
        c, s = math.cos(h), math.sin(h)
        if not all(reachable(cfg, tx - r * c, ty - r * s, h, elbow) for r in (0.0, STAND_OFF)):
            continue
        lead_y = ty - LEAD_IN * s
        if lead_y < 0.03:  # the lead-in point must be over the table
            continue
        out.append((intrusion(cfg, st, h), abs(delta), Corridor(h, intrusion(cfg, st, h))))
    out.sort(key=lambda t: (t[0], t[1]))
    return [c for _, _, c in out]


def _steer(px, py, wx, wy, speed: float, max_speed: float) -> tuple[float, float]:
    """Saturated P-control toward (wx, wy), as a normalised velocity command."""
    vx, vy = GAIN * (wx - px), GAIN * (wy - py)
    norm = math.hypot(vx, vy)
    cap = speed * max_speed
    if norm > cap:
        vx, vy = vx * cap / norm, vy * cap / norm
    return vx / max_speed, vy / max_speed


def corridor_action(world: GraspWorld, heading: float) -> tuple[np.ndarray, str]:
    """The trajectory and control levels: the action toward the current waypoint of the corridor
    with gripper heading ``heading``, and the name of the waypoint phase.

    The phase is a function of the state: close (the target is between the fingers), advance
    (on the corridor's line and aligned: to the target), approach (on the corridor before the
    stand-off: along it, which turns the trailing gripper onto it), align (at the stand-off, not
    yet aligned: creep along the line), retract (off the corridor inside the clutter: back out),
    transit (elsewhere: to the lead-in point, around the clutter if the straight path crosses it).
    """
    cfg, st = world.cfg, world.state
    px, py, h = world.end_effector()
    tx, ty = st.poses[TARGET, 0], st.poses[TARGET, 1]
    c, s = math.cos(heading), math.sin(heading)
    rx, ry = px - tx, py - ty
    along = rx * c + ry * s  # < 0 before the target
    lateral = -rx * s + ry * c
    dist = math.hypot(rx, ry)
    ms = cfg.max_speed

    near = dist < cfg.finger_length + cfg.grasp_offset  # only then can it be between the fingers
    if (
        near
        and (st.gripper > 0.0 or along > -0.01)
        and any(i == TARGET for i, _ in world.between_fingers())
    ):
        return np.array([0.0, 0.0, 1.0]), "close"
    heading_err = abs(wrap(h - heading))
    if abs(lateral) < 0.025 and -STAND_OFF - 0.03 <= along <= 0.0 and heading_err < ALIGNED:
        forward = min(ADVANCE_SPEED, GAIN * (0.004 - along) / ms)
        if abs(lateral) > 0.01:
            forward = min(forward, CREEP)  # mostly correct the offset first
        vx = forward * c + LATERAL_GAIN * lateral * s
        vy = forward * s - LATERAL_GAIN * lateral * c
        return np.array([vx, vy, 0.0]), "advance"
    if abs(lateral) < 0.035 and -LEAD_IN - 0.05 <= along <= -FINGER_CLEAR:
        if along >= -STAND_OFF - 0.01:
            if heading_err < ALIGNABLE:
                # at the stand-off, nearly aligned: creep on a course that overshoots the
                # heading error, so the trailing gripper turns faster than the course drifts
                err = wrap(heading - h)
                course = heading + max(-0.5, min(0.5, err))
                vx = CREEP * math.cos(course) + 0.5 * LATERAL_GAIN * lateral * s
                vy = CREEP * math.sin(course) - 0.5 * LATERAL_GAIN * lateral * c
                return np.array([vx, vy, 0.0]), "align"
        else:
            ahead = max(STAND_OFF, -along - 0.06)  # pure pursuit of a point 6 cm down the line
            speed = 1.0 if heading_err < math.radians(30.0) else 0.6  # leave time to turn
            vx, vy = _steer(px, py, tx - ahead * c, ty - ahead * s, speed, ms)
            return np.array([vx, vy, 0.0]), "approach"
    if dist < CLUTTER - 0.02:
        # off the corridor inside the clutter: back out, away from the target
        ux, uy = rx / max(dist, 1e-9), ry / max(dist, 1e-9)
        bx, by = -math.cos(h), -math.sin(h)
        if bx * ux + by * uy > 0.0:
            ux, uy = bx, by  # backing out along the gripper keeps its heading
        return np.array([ux, uy, 0.0]), "retract"
    # transit to the lead-in point, around the cluster if the straight path would cross it
    lx, ly = tx - LEAD_IN * c, ty - LEAD_IN * s
    if _seg_dist(tx, ty, px, py, lx, ly) < CLUTTER - 0.01:
        a0 = math.atan2(ry, rx)
        turn = wrap(math.atan2(ly - ty, lx - tx) - a0)
        a = a0 + math.copysign(min(abs(turn), math.radians(50.0)), turn)
        wx, wy = tx + (CLUTTER + 0.02) * math.cos(a), ty + (CLUTTER + 0.02) * math.sin(a)
    else:
        wx, wy = lx, ly
    vx, vy = _steer(px, py, wx, wy, 1.0, ms)
    return np.array([vx, vy, 0.0]), "transit"


def execute(world: GraspWorld, action: np.ndarray) -> None:
    """Apply a normalised action to the world (as the env does, without noise)."""
    ms = world.cfg.max_speed
    world.step(float(action[0]) * ms, float(action[1]) * ms, bool(action[2] >= 0.5))


@dataclass
class Outcome:
    cost: float
    steps: int
    disturbance: float  # summed obstacle displacement (m)

    @property
    def key(self) -> tuple[float, float, float]:
        return (self.cost, round(self.disturbance, 3), self.steps)


def foresee(cfg: GraspConfig, st: WorldState, heading: float, horizon: int) -> Outcome:
    """Roll the corridor's trajectory and control levels out on a world rebuilt from ``st``,
    until the target is grasped or knocked off, or it moved more than :data:`REPLAN_MOVE` (the
    live run would replan there, so the corridor's own future ends), or ``horizon`` steps."""
    world = GraspWorld.from_state(cfg, st)
    start = st.poses[:, :2].copy()
    tx, ty = start[TARGET]
    steps = 0
    target = world.state.poses[TARGET]
    while steps < horizon and not world.state.grasped and world.state.on_table[TARGET]:
        action, _ = corridor_action(world, heading)
        execute(world, action)
        steps += 1
        if math.hypot(target[0] - tx, target[1] - ty) > REPLAN_MOVE:
            break
    moved = np.hypot(*(world.state.poses[:, :2] - start).T)
    moved[~world.state.on_table] = 0.0
    cost = world.state.knocked + (0 if world.state.grasped else 10)
    return Outcome(float(cost), steps, float(moved.sum()))


class GraspSupervisor:
    """Plans a corridor with foresight, caches it, and labels every state from it."""

    def __init__(
        self,
        cfg: GraspConfig,
        fan_deg: tuple[float, ...] = tuple(range(-90, 91, 15)),
        foresight: int = 7,
        horizon: int = 60,
    ) -> None:
        self.cfg = cfg
        self.fan_deg = fan_deg
        self.foresight = foresight
        self.horizon = horizon
        self.plan_: Plan | None = None
        self.overran: list[float] = []  # headings of this episode's plans that ran long
        self.replans = 0
        self.replan_seconds = 0.0
        self.last_replan_seconds = 0.0

    def reset(self) -> None:
        self.plan_ = None
        self.overran: list[float] = []
        self.replans, self.replan_seconds = 0, 0.0

    # -- behaviour -------------------------------------------------------------------------

    def plan(self, world: GraspWorld) -> Plan:
        start = time.process_time()
        st = world.state
        ranked = rank_corridors(self.cfg, st, self.fan_deg)
        fresh = [c for c in ranked if all(abs(wrap(c.heading - h)) > 1e-6 for h in self.overran)]
        ranked = fresh or ranked
        if not ranked:  # nothing reachable by the rules: take the radial approach anyway
            tx, ty = st.poses[TARGET, 0], st.poses[TARGET, 1]
            ranked = [Corridor(math.atan2(ty, tx), 0.0)]
        best: tuple[tuple[float, float, float], Corridor, Outcome] | None = None
        for corridor in ranked[: self.foresight]:
            outcome = foresee(self.cfg, st, corridor.heading, self.horizon)
            if best is None or outcome.key < best[0]:
                best = (outcome.key, corridor, outcome)
            if outcome.cost == 0:
                break  # the best cost there is: stop looking (ranked order breaks ties)
        assert best is not None
        _, corridor, outcome = best
        self.plan_ = Plan(
            corridor,
            (float(st.poses[TARGET, 0]), float(st.poses[TARGET, 1])),
            st.steps,
            outcome.steps,
            outcome.cost,
        )
        self.last_replan_seconds = time.process_time() - start
        self.replan_seconds += self.last_replan_seconds
        self.replans += 1
        return self.plan_

    def _plan_holds(self, world: GraspWorld) -> bool:
        plan, st = self.plan_, world.state
        if plan is None or st.steps < plan.start_step:
            return False
        tx, ty = st.poses[TARGET, 0], st.poses[TARGET, 1]
        if math.hypot(tx - plan.target_xy[0], ty - plan.target_xy[1]) > REPLAN_MOVE:
            return False
        if st.steps - plan.start_step > plan.predicted_steps + REPLAN_SLACK:
            self.overran.append(plan.corridor.heading)  # stuck: try another corridor next
            return False
        # an obstacle moved into the corridor since the plan (caught in the jaws' path, or
        # grazing the swept strip 1 cm deeper)
        now = intrusion(self.cfg, st, plan.corridor.heading)
        return now < plan.corridor.intrusion + REPLAN_INTRUSION

    def action(self, world: GraspWorld) -> np.ndarray:
        """The label: the normalised action (vx, vy, grip) for the world's current state."""
        if not self._plan_holds(world):
            self.plan(world)
        assert self.plan_ is not None
        action, _ = corridor_action(world, self.plan_.corridor.heading)
        np.clip(action, (-1.0, -1.0, 0.0), (1.0, 1.0, 1.0), out=action)
        return action
