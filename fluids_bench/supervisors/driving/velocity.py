"""Level 3 of the supervisor: a velocity planner posed as a constraint-satisfaction problem.

For every agent and every candidate target velocity (fractions of what its path allows there),
the planner projects the agent forward along its path for ``horizon`` seconds under the same
speed law the controller follows. Pairs of agents whose projections at a pair of candidates come
closer than their footprints allow are a binary constraint; lights and crosswalks prune the
domains (unary constraints). python-constraint2 then assigns every agent a velocity.

* Higher velocities first: domains are listed ascending, and the solver tries a domain's values
  from the end.
* Priority: variables are assigned in a fixed order (agents in or past the junction first, the
  furthest along first; then the others, nearest the junction first; then by index), so the
  agent that committed first keeps its right of way and the plan is deterministic.
* Always feasible: a pair only conflicts when a candidate pair brings the agents closer than
  they are now, so everyone stopping satisfies every constraint, and a stop is never pruned.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from constraint import FunctionConstraint, OptimizedBacktrackingSolver, Problem

from fluids_bench.sim.config import check_range
from fluids_bench.sim.layout.geometry import PATH_SPACING
from fluids_bench.sim.lights import CAUTION, STOP
from fluids_bench.sim.world import World


@dataclass(frozen=True)
class VelocityPlannerConfig:
    horizon: float = 4.0  # s of forward projection
    sample_every: int = 2  # compare positions every this many sim steps of the projection
    fractions: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)  # of the agent's allowed speed
    margin: float = 0.5  # m of clearance kept between footprint circles
    lateral_accel: float = 2.5  # m/s², sets the speed allowed on curves
    speed_gain: float = 2.0  # 1/s, the controller's speed loop gain (projection mirrors it)
    max_accel: float = 2.5  # m/s² the controller asks for at most
    max_decel: float = 5.0  # m/s² the controller brakes at most
    period: int = 1  # plan every this many steps; hold the plan in between

    def __post_init__(self) -> None:
        check_range("VelocityPlannerConfig", "horizon", self.horizon, 0.5, 20.0)
        check_range("VelocityPlannerConfig", "sample_every", self.sample_every, 1, 10, integer=True)
        check_range("VelocityPlannerConfig", "margin", self.margin, 0.0, 5.0)
        check_range("VelocityPlannerConfig", "period", self.period, 1, 50, integer=True)
        fr = self.fractions
        if not fr or fr[0] != 0.0 or list(fr) != sorted(set(fr)) or fr[-1] > 1.0:
            raise ValueError(f"VelocityPlannerConfig: field 'fractions' is {fr!r}; allowed: "
                             "ascending distinct values in [0, 1] starting at 0.0")


class _PrioritySolver(OptimizedBacktrackingSolver):
    """Backtracking with a caller-given variable order (the priority order)."""

    def __init__(self, order: list[int]) -> None:
        super().__init__()
        self.order = order

    def getSortedVariables(self, domains, vconstraints):  # noqa: N802 (library's name)
        return [v for v in self.order if v in domains]


def _circle_layout(world: World) -> tuple[np.ndarray, np.ndarray]:
    """Three circles per agent along its length: offsets (N, 3) and radius (N,)."""
    offs = np.column_stack([-world.length / 3, np.zeros(world.n), world.length / 3])
    offs = np.where(world.is_car[:, None], offs, 0.0)
    radius = np.where(world.is_car, np.hypot(world.length / 6, world.width / 2), world.width / 2)
    return offs, radius


class VelocityPlanner:
    """Assigns every active agent a target velocity (m/s) each planning tick."""

    def __init__(self, config: VelocityPlannerConfig | None = None) -> None:
        self.config = config or VelocityPlannerConfig()
        self.fractions = np.asarray(self.config.fractions)

    def allowed_speed(self, world: World) -> np.ndarray:
        """Speed each agent may drive at now: its maximum, the lane's limit, and the curvature
        of the path ahead (within its braking distance plus a car length)."""
        cfg = self.config
        routes = world.layout.routes
        look = np.arange(0, 24)  # 12 m of path ahead
        k = np.clip(np.rint(world.s / PATH_SPACING).astype(np.int64)[:, None] + look, 0, routes.path.shape[1] - 1)
        r = np.maximum(world.route, 0)[:, None]
        kappa = routes.curvature[r, k].max(axis=1)
        limit = routes.speed_limit[r[:, 0], k[:, 0]]
        curve = np.sqrt(cfg.lateral_accel / np.maximum(kappa, 1e-6))
        out = np.minimum(world.max_speed, np.minimum(limit, curve))
        return np.where(world.is_car, out, world.max_speed)

    # ------------------------------------------------------------------ projection
    def project(self, world: World, targets: np.ndarray) -> np.ndarray:
        """Arc lengths (N, K, T) reached under each candidate target speed (N, K) (m/s).

        The speed law mirrors the PID's: v' = clip(gain · (v_target − v), −decel, accel).
        """
        cfg = self.config
        steps = int(round(cfg.horizon / world.dt))
        v = np.repeat(world.state[:, 3:4], targets.shape[1], axis=1)
        ds = np.empty((steps, *targets.shape))
        for t in range(steps):
            a = np.clip(cfg.speed_gain * (targets - v), -cfg.max_decel, cfg.max_accel)
            v_next = np.maximum(v + a * world.dt, 0.0)
            ds[t] = 0.5 * (v + v_next) * world.dt
            v = v_next
        travelled = np.cumsum(ds, axis=0)[cfg.sample_every - 1 :: cfg.sample_every]
        return world.s[:, None, None] + np.moveaxis(travelled, 0, -1)

    # ------------------------------------------------------------------ constraints
    def domains(self, world: World, s_proj: np.ndarray, vmax: np.ndarray) -> np.ndarray:
        """Unary constraints: allowed[i, k] is False where candidate k runs a stop light.

        Stop (red, or "don't walk"): the agent's front may not pass its stop line within the
        horizon. Yellow: the same, unless it is too close to stop comfortably. An agent already
        committed past the line (or unable to stop before it) is not held back.
        """
        routes = world.layout.routes
        allowed = np.ones(s_proj.shape[:2], dtype=bool)
        r = world.route
        light = np.where(r >= 0, routes.light[np.maximum(r, 0)], -1)
        stop_s = routes.stop_s[np.maximum(r, 0)]
        front = np.where(world.is_car, world.length / 2, world.width / 2)
        gap = stop_s - (world.route_s + front)
        governed = world.active & (light >= 0) & (gap > -0.5)
        if not governed.any():
            return allowed
        state = np.where(light >= 0, world.light_state[np.maximum(light, 0)] if len(world.light_state) else 0, 0)
        v = world.state[:, 3]
        brake = v**2 / (2 * 0.6 * self.config.max_decel)  # comfortable braking distance
        holds = governed & ((state == STOP) | ((state == CAUTION) & (brake < gap)))
        crosses = (s_proj.max(axis=2) + world.offset[:, None] + front[:, None]) > stop_s[:, None]
        blocked = holds[:, None] & crosses
        can_stop = ~blocked[:, 0]  # the slowest candidate stops in time
        allowed &= ~(blocked & can_stop[:, None])
        return allowed

    def conflicts(self, world: World, s_proj: np.ndarray, vmax: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Candidate pairs (P, 2) and conflict[p, a, b] for each pair of candidates."""
        act = np.flatnonzero(world.active)
        if len(act) < 2:
            return np.zeros((0, 2), dtype=np.int64), np.zeros((0, len(self.fractions), len(self.fractions)), bool)
        pos = world.state[:, :2]
        reach = vmax * self.config.horizon + world.length + self.config.margin
        ii, jj = np.triu_indices(len(act), k=1)
        i, j = act[ii], act[jj]
        # pedestrians step round each other: only pairs with a car constrain anyone
        near = (np.hypot(*(pos[i] - pos[j]).T) < reach[i] + reach[j]) & (world.is_car[i] | world.is_car[j])
        i, j = i[near], j[near]
        if len(i) == 0:
            return np.zeros((0, 2), dtype=np.int64), np.zeros((0, len(self.fractions), len(self.fractions)), bool)
        agents = np.unique(np.concatenate([i, j]))
        offs, radius = _circle_layout(world)
        bound = np.where(world.is_car, np.hypot(world.length, world.width) / 2, world.width / 2)
        slot = np.zeros(world.n, dtype=np.int64)
        slot[agents] = np.arange(len(agents))
        ia, ja = slot[i], slot[j]
        pts, head = world.path_points(s_proj[agents], agents)  # (A, K, T, 2), (A, K, T)
        # broad phase: centre distances for every pair, candidate pair and time
        dc = np.linalg.norm(pts[ia][:, :, None] - pts[ja][:, None, :], axis=-1)  # (P, K, K, T)
        near = dc < (bound[i] + bound[j] + self.config.margin)[:, None, None, None]
        conflict = np.zeros(dc.shape[:3], dtype=bool)
        p, a, b, t = np.nonzero(near)
        if len(p):
            # narrow phase, only where the bounding circles meet: three circles per car
            th = world.state[:, 2]
            pos_now = world.state[:, :2]
            now = pos_now[:, None, :] + offs[:, :, None] * np.stack([np.cos(th), np.sin(th)], -1)[:, None, :]
            d_now = np.linalg.norm(now[i][:, :, None] - now[j][:, None, :], axis=-1).min(axis=(1, 2))
            thresh = np.minimum(radius[i] + radius[j] + self.config.margin, d_now - 0.05)
            hi, hj = head[ia[p], a, t], head[ja[p], b, t]
            ci = pts[ia[p], a, t][:, None, :] + offs[i[p]][:, :, None] * np.stack([np.cos(hi), np.sin(hi)], -1)[:, None, :]
            cj = pts[ja[p], b, t][:, None, :] + offs[j[p]][:, :, None] * np.stack([np.cos(hj), np.sin(hj)], -1)[:, None, :]
            d = np.linalg.norm(ci[:, :, None] - cj[:, None, :], axis=-1).min(axis=(1, 2))
            hit = d < thresh[p]
            conflict[p[hit], a[hit], b[hit]] = True
        conflict[:, 0, 0] = False  # both braking is always allowed: the CSP stays feasible
        keep = conflict.any(axis=(1, 2))
        return np.column_stack([i, j])[keep], conflict[keep]

    def priority(self, world: World) -> list[int]:
        """Agents in the order the solver assigns them (highest right of way first)."""
        routes = world.layout.routes
        enter = routes.enter_s[np.maximum(world.route, 0)]
        front = np.where(world.is_car, world.length / 2, world.width / 2)
        rs = world.route_s
        inside = rs + front >= enter
        key_inside = np.where(inside, -(rs - enter), np.inf)
        key_out = np.where(inside, -np.inf, enter - rs)
        order = np.lexsort((np.arange(world.n), key_out, key_inside, ~inside))
        return [int(a) for a in order if world.active[a]]

    # ------------------------------------------------------------------ solve
    def plan(self, world: World) -> np.ndarray:
        """Target velocity (m/s) of every agent; 0 for inactive ones."""
        vmax = self.allowed_speed(world)
        targets = vmax[:, None] * self.fractions[None, :]
        s_proj = self.project(world, targets)
        allowed = self.domains(world, s_proj, vmax)
        pairs, conflict = self.conflicts(world, s_proj, vmax)
        choice = np.array([np.flatnonzero(row).max() if row.any() else 0 for row in allowed])
        if len(pairs):
            problem = Problem(_PrioritySolver(self.priority(world)))
            for a in np.unique(pairs):
                problem.addVariable(int(a), [int(k) for k in np.flatnonzero(allowed[a])] or [0])
            for (a, b), table in zip(pairs, conflict, strict=True):
                ok = frozenset(zip(*np.nonzero(~table), strict=True))
                problem.addConstraint(FunctionConstraint(lambda x, y, ok=ok: (x, y) in ok), [int(a), int(b)])
            solution = problem.getSolution()
            if solution is None:  # cannot happen (all-stop is feasible); fail loudly if it does
                raise RuntimeError("velocity CSP has no solution; the all-stop invariant is broken")
            for a, k in solution.items():
                choice[a] = k
        out = targets[np.arange(world.n), choice]
        return np.where(world.active, out, 0.0)
