"""Level 3 of the supervisor: a velocity planner posed as a constraint-satisfaction problem.

For every agent and every candidate target velocity (fractions of what its path allows there),
the planner projects the agent forward along its path for `horizon` seconds under the same
speed law the controller follows. Pairs of agents whose projections at a pair of candidates come
closer than their footprints allow are a binary constraint; lights and crosswalks prune the
domains (unary constraints). A backtracking solver then assigns every agent a velocity
(`.csp_kernels`: compiled, the same search as python-constraint2's
`OptimizedBacktrackingSolver`, which the tests keep as its reference).

* Higher velocities first: domains are listed ascending, and the solver tries a domain's values
  from the end.
* Priority: variables are assigned in a fixed order (agents in or past the junction first, the
  furthest along first; then the others, nearest the junction first; then by index), so the
  agent that committed first keeps its right of way and the plan is deterministic.
* Always feasible: a candidate pair conflicts only when it brings the agents closer than both
  their clearance and their distance now; both braking never conflicts and braking is never
  pruned from a domain, so everyone braking satisfies every constraint.
* Pedestrians are agents like cars: they obey crosswalk lights (unary constraints) and, having
  no right of way over a car already in the crosswalk, wait for it (priority order). Pairs of
  pedestrians are not constrained: they step round each other.
* Pedestrians' right of way (`yield_to_pedestrians`): a crosswalk with a walker on it is a
  stop line for the cars whose route crosses it, and walkers wait at the kerb while a car is
  too close to stop for them (`fluids_bench.tasks.fluids.sim.crosswalks`).
* Defensive toward agents it does not control (`plan(world, uncontrolled)`; the learner's ego,
  the multi-agent env's cars): such an agent may brake as hard as its limits allow at any time.
  A supervised agent's candidate is allowed only if, holding it until the next plan and then
  braking, the agent stops short of every place the uncontrolled one can stop in that time
  (it brakes now, or a few steps from now after holding its speed). By induction over plans,
  braking at the next plan is then still safe, so a supervised agent never runs into an
  uncontrolled one that stops, wherever physics lets it stop (one that cuts in inside its
  braking distance excepted). An uncontrolled agent running into a supervised one from behind
  is its own doing and is not guarded against (see `fluids_bench.tasks.fluids.sim.fault`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fluids_bench.core.validation import check_bool
from fluids_bench.tasks.fluids.sim.config import check_range
from fluids_bench.tasks.fluids.sim.crosswalks import crosswalks_of
from fluids_bench.tasks.fluids.sim.fault import STATIONARY_SPEED, route_turns, turns_across
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.csp_kernels import plan_choice
from fluids_bench.tasks.fluids.supervisor.defensive_kernels import defensive_forbid
from fluids_bench.tasks.fluids.supervisor.kernels import (
    allowed_speeds,
    circle_gaps,
    plan_conflicts,
    projected_arc_lengths,
)
from fluids_bench.tasks.fluids.supervisor.plan_kernels import plan_head, plan_tail
from fluids_bench.tasks.fluids.supervisor.stop_line_kernels import stop_lines

CURVE_LOOK_AHEAD = 24  # path samples (12 m) ahead whose curvature limits the speed now
GIVE_WAY_HORIZON = 8.0  # s projected when giving way to an uncontrolled agent (_give_way)
GIVE_WAY_LOOK_AHEAD = 40.0  # m of route whose curves slow a car that goes on (_give_way)


@dataclass(frozen=True)
class VelocityPlannerConfig:
    horizon: float = 4.0  # s of forward projection
    sample_every: int = 2  # compare positions every this many sim steps of the projection
    fractions: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)  # of the agent's allowed speed
    margin: float = 0.5  # m of clearance kept between footprint circles
    pedestrian_margin: float = 0.25  # m between a car and a walker on a crossing (cars creep past)
    lateral_accel: float = 2.5  # m/s², sets the speed allowed on curves
    speed_gain: float = 2.0  # 1/s, the controller's speed loop gain (projection mirrors it)
    max_accel: float = 2.5  # m/s² the controller asks for at most
    max_decel: float = 5.0  # m/s² the controller brakes at most
    period: int = 5  # plan every this many steps (0.5 s at dt = 0.1); hold the plan in between
    # cars wait before a crosswalk with a pedestrian on it (off: they creep past walkers)
    yield_to_pedestrians: bool = False

    def __post_init__(self) -> None:
        check_range("VelocityPlannerConfig", "horizon", self.horizon, 0.5, 20.0)
        check_range("VelocityPlannerConfig", "sample_every", self.sample_every, 1, 10, integer=True)
        check_range("VelocityPlannerConfig", "margin", self.margin, 0.0, 5.0)
        check_range("VelocityPlannerConfig", "pedestrian_margin", self.pedestrian_margin, 0.0, 5.0)
        # all four divide in the projection (max_decel = 0 divided by zero)
        check_range("VelocityPlannerConfig", "lateral_accel", self.lateral_accel, 0.1, 20.0)
        check_range("VelocityPlannerConfig", "speed_gain", self.speed_gain, 0.1, 10.0)
        check_range("VelocityPlannerConfig", "max_accel", self.max_accel, 0.1, 50.0)
        check_range("VelocityPlannerConfig", "max_decel", self.max_decel, 0.1, 50.0)
        check_range("VelocityPlannerConfig", "period", self.period, 1, 50, integer=True)
        check_bool("VelocityPlannerConfig", "yield_to_pedestrians", self.yield_to_pedestrians)
        fr = self.fractions
        if not fr or fr[0] != 0.0 or list(fr) != sorted(set(fr)) or fr[-1] > 1.0:
            raise ValueError(
                f"VelocityPlannerConfig: field 'fractions' is {fr!r}; allowed: "
                "ascending distinct values in [0, 1] starting at 0.0"
            )


def _circle_layout(world: World) -> tuple[np.ndarray, np.ndarray]:
    """Three circles per agent along its length: offsets (N, 3) and radius (N,)."""
    offs = np.column_stack([-world.length / 3, np.zeros(world.n), world.length / 3])
    offs = np.where(world.is_car[:, None], offs, 0.0)
    radius = np.where(world.is_car, np.hypot(world.length / 6, world.width / 2), world.width / 2)
    return offs, radius


# what VelocityPlanner._compute_constants sets, shared per (layout, scene, config) in _BOUND
_CONSTANTS = (
    "_none_uncontrolled", "_brake_limit", "_offs", "_radius", "_offs32", "_reach", "_front",
    "_crosswalks", "_turns", "_decay", "_across", "_hold_wild", "_ints", "_floats",
)  # fmt: skip
_BOUND: dict[tuple, dict] = {}


class VelocityPlanner:
    """Assigns every active agent a target velocity (m/s) each planning tick."""

    def __init__(self, config: VelocityPlannerConfig | None = None) -> None:
        self.config = config or VelocityPlannerConfig()
        self.fractions = np.asarray(self.config.fractions)

    def allowed_speed(self, world: World, agents: np.ndarray) -> np.ndarray:
        """Speed each of `agents` may drive at now: its maximum, the lane's limit, and the
        curvature of the next 12 m of its route."""
        routes = world.layout.routes
        return allowed_speeds(
            agents,
            world.s,
            world.offset,
            world.route,
            world.is_car,
            world.max_speed,
            routes.curvature,
            routes.speed_limit,
            CURVE_LOOK_AHEAD,
            self.config.lateral_accel,
            PATH_SPACING,
        )

    # ------------------------------------------------------------------ projection
    def project(self, world: World, agents: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """Path arc lengths (A, K, T) of `agents` under each candidate target speed (A, K).

        The speed law is the PID's, in the simulator's discrete time:
        v[n+1] = v[n] + clip(gain · (v_target − v[n]), −decel, accel) · dt. It is solved in closed
        form: a saturated, linear phase of `n1` steps, then a geometric approach at rate
        (1 − gain · dt) per step. Positions are sampled every `sample_every` steps.
        """
        cfg, dt = self.config, world.dt
        return projected_arc_lengths(
            world.s[agents],
            world.state[agents, 3],
            targets,
            self._decay,
            int(round(cfg.horizon / dt)),
            cfg.sample_every,
            dt,
            cfg.max_accel,
            cfg.max_decel,
            cfg.speed_gain,
        )

    # ------------------------------------------------------------------ constraints
    def domains(self, world: World, agents: np.ndarray, s_proj: np.ndarray) -> np.ndarray:
        """Unary constraints: allowed[a, k] is False where candidate k runs a stop light (or,
        with `yield_to_pedestrians`, drives onto a crosswalk with a pedestrian on it).

        Stop (red, or "don't walk"): the agent's front may not pass its stop line within the
        horizon. Yellow: the same, unless it is too close to stop comfortably. An agent already
        committed past the line (or unable to stop before it) is not held back. An occupied
        crosswalk ahead is a stop line at its near edge for the cars whose route crosses it,
        with the same exceptions.
        """
        return self._domains_and_hold_lines(world, agents, s_proj)[0]

    def _domains_and_hold_lines(
        self, world: World, agents: np.ndarray, s_proj: np.ndarray, uncontrolled=None
    ) -> tuple[np.ndarray, np.ndarray]:
        """`domains`, and the route arc length (A,) of the first stop line each agent
        will hold before (one it can still stop for; `inf` where none)."""
        allowed, line, _ = self._stop_lines(
            world, agents, self._front[agents], s_proj, uncontrolled
        )
        return allowed, line

    def _stop_lines(self, world: World, agents, front, s_proj, uncontrolled=None):
        """(allowed, line, stops) of `stop_line_kernels.stop_lines`: the stop lines each
        of `agents` (fronts `front`, m) must hold at (its light: red; yellow if it can
        still brake comfortably, and so, with `yield_to_pedestrians`, a walker's white
        light that turns red before it would reach its crosswalk at its speed, or half a
        walking pace from rest, plus a planning period: the flashing "don't walk" crosswalk
        lights lack; with `yield_to_pedestrians`, a crosswalk with a walker on it ahead of
        a car, and for a walker the kerb while a car is committed to that crosswalk or a
        supervised car turning left is inside the junction on its way out across it, so that
        a car that yields is not cut off and a walker does not strand a car across the
        oncoming lane; `uncontrolled` (N,) bool: the cars that do not count for that)."""
        lights, routes, cw = world.lights, world.layout.routes, self._crosswalks
        if uncontrolled is None:
            uncontrolled = np.zeros(world.n, dtype=bool)
        return stop_lines(
            agents,
            np.ascontiguousarray(front, dtype=np.float64),
            s_proj,
            world.state,
            world.s,
            world.offset,
            self._front,
            world.is_car,
            world.active,
            world.width,
            world.route,
            world.entered,
            world.max_speed,
            uncontrolled,
            routes.light,
            routes.stop_s,
            world.light_state,
            lights.ends,
            lights.cycle,
            lights.offset,
            world.time,
            cw.centre,
            cw.axis,
            cw.half,
            cw.car_enter,
            cw.walk_crosswalk,
            cw.walk_enter,
            self._turns[1],
            self.config.max_decel,
            self.config.yield_to_pedestrians,
            self.config.period * world.dt,
        )

    def _light_stops(self, world: World, agents: np.ndarray, front: np.ndarray):
        """Each agent's stop line where its light holds it (see `_stop_lines`), `inf`
        where none does; None when no light holds anyone."""
        horizon = np.zeros((len(agents), 1, 1))  # no candidate to prune: the lines only
        stops = self._stop_lines(world, agents, front, horizon)[2][0]
        return stops if np.isfinite(stops).any() else None

    def conflicts(
        self, world: World, agents: np.ndarray, s_proj: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (P, 2) of positions in `agents` and conflict[p, a, b] per candidate pair.

        Only pairs with a car are checked (pedestrians step round each other). A pair already
        closer than its clearance conflicts only where it gets closer still, so that braking
        stays feasible for the CSP; the smaller car-pedestrian clearance applies once the
        walker is on the crossing (so a car can creep past it), a walker still at the kerb
        keeps the full one. The per-pair, per-candidate, per-time loop is compiled
        (`kernels.plan_conflicts`); the distance now between footprint circles stays
        numpy's complex arithmetic (its vectorised complex abs is the reference).
        """
        k = len(self.fractions)
        ii, jj, gaps = circle_gaps(agents, world.state, world.is_car, self._offs32)
        if not len(ii):
            return np.zeros((0, 2), dtype=np.int64), np.zeros((0, k, k), dtype=bool)
        d_now = np.abs(gaps).min(axis=1)  # numpy's complex abs: see circle_gaps
        cfg = self.config
        return plan_conflicts(
            agents,
            s_proj,
            ii,
            jj,
            d_now,
            world.state,
            world.s,
            world.offset,
            self._front,
            world.is_car,
            world.route,
            world.layout.routes.enter_s,
            self._offs32,
            self._radius,
            self._reach,
            world.path_c64,
            world.path_dir,
            1.0 / PATH_SPACING,
            cfg.margin,
            cfg.pedestrian_margin,
        )

    def defensive_domains(
        self,
        world: World,
        agents: np.ndarray,
        targets: np.ndarray,
        wild: np.ndarray,
        hold_lines: np.ndarray | None = None,
    ) -> np.ndarray:
        """Unary constraints toward uncontrolled agents: allowed[a, k] is False where supervised
        agent `a`, holding candidate k until the next plan and braking then, could run into an
        uncontrolled agent (`wild`, positions in `agents`) that brakes as hard as it can
        now or at any of a few later steps before the next plan (holding its speed until then).
        Guarding against every uncontrolled agent keeping its speed was tried: supervised cars
        then hesitated so much that a supervisor-driven ego timed out in 1-2% of episodes; the
        give-way rule below does it only toward one with the right of way.

        Pairs in which the uncontrolled agent follows the supervised one (within 45° of its
        heading, behind it) are skipped: a rear-end is the follower's fault. The clearance is
        the full one, not relaxed to the distance now: positions are path samples
        (PATH_SPACING apart), so a relaxed check would let a car creep on, a rounding step at a
        time, into an uncontrolled one already near it. Braking now (candidate 0) is never
        pruned, so the CSP stays feasible.

        Followers: with uncontrolled agents about, a supervised leader may have to brake at
        once, which its followers' plans did not foresee; a supervised car behind another in its
        lane (within 45°, less than 2 m aside) may not take a candidate that runs into the
        leader braking now, unless none helps any more.

        Giving way: toward an uncontrolled agent with the right of way over it by the rules that
        assign fault (`..sim.fault`: it entered its shared zone first, rule 7, or it comes
        the other way and goes straight while the supervised one turns across its path, rule
        6), a candidate is safe if, holding it until the next plan and then braking, the agent
        stops short of that agent's path, or if, holding it, it clears the path before that
        agent gets there (gap acceptance), whether that agent keeps its speed or speeds up (at
        the controller's acceleration, to the fastest speed allowed to it; one at rest is taken
        to stay there, so that a waiting ego and a waiting car do not deadlock). Both scenarios
        end at the agent's hold line (`hold_lines`: route arc lengths of the stop lines it
        will hold before, as `plan` finds them with the domains; default: none): it does
        not enter a crossing that it would have to stop in (don't block the box). Everything
        is projected over `GIVE_WAY_HORIZON`, long enough for a car turning from rest to
        clear a crossing, and going on it slows for the curves of the next
        `GIVE_WAY_LOOK_AHEAD` metres; the agent keeps a planning period to spare before
        it brakes. Where no candidate keeps the full clearance both ways, the candidates that
        at least do not touch that agent either way are kept; an agent with none at all (it is
        already in the way) is left as it is. Braking now that is unsafe both ways (it cannot
        stop short of where the uncontrolled agent may stop, and it would stop in the path of
        one that keeps going) while going on clears that path: it clears the crossing rather
        than stop in it.

        One compiled call (`defensive_kernels.defensive_forbid`).
        """
        self._bind(world)
        if hold_lines is None:
            hold_lines = np.full(len(agents), np.inf)
        routes = world.layout.routes
        forbid = defensive_forbid(
            agents,
            np.ascontiguousarray(wild, dtype=np.bool_),
            np.ascontiguousarray(targets, dtype=np.float64),
            np.ascontiguousarray(hold_lines, dtype=np.float64),
            world.state,
            world.s,
            world.offset,
            self._front,
            world.is_car,
            world.entered,
            world.route,
            world.max_speed,
            self._brake_limit,
            self._offs32,
            self._radius,
            self._reach,
            world.path_c64,
            world.path_dir,
            routes.enter_s,
            self._across,
            routes.curvature,
            routes.speed_limit,
            self.fractions,
            self._hold_wild,
            self._ints,
            self._floats,
        )
        return ~forbid

    # ------------------------------------------------------------------ solve
    def _bind(self, world: World) -> None:
        """Per-world constants (footprint circles, route tables): they depend only on the
        layout, the scene and the planner's config, so they are computed once for each and
        shared by the planners of every world of that kind (a reset makes a new planner)."""
        if getattr(self, "_bound_world", None) is world:
            return
        self._bound_world = world
        key = (world.layout, world.scene, self.config)
        constants = _BOUND.get(key)
        if constants is None:
            if len(_BOUND) >= 64:  # many scenes (a sweep): keep the cache small
                _BOUND.clear()
            self._compute_constants(world)
            constants = _BOUND[key] = {k: getattr(self, k) for k in _CONSTANTS}
        self.__dict__.update(constants)

    def _compute_constants(self, world: World) -> None:
        self._none_uncontrolled = np.zeros(world.n, dtype=bool)
        scene = world.scene
        self._brake_limit = np.where(
            world.is_car, scene.car.max_brake_force / world.params[:, 0], scene.pedestrian.max_accel
        )  # m/s², each agent's hardest braking
        self._offs, self._radius = _circle_layout(world)
        self._offs32 = self._offs.astype(np.float32)
        bound = np.where(world.is_car, np.hypot(world.length, world.width) / 2, world.width / 2)
        self._reach = bound + self.config.margin / 2  # bounding circle plus half the clearance
        self._front = world.front
        self._crosswalks = crosswalks_of(world.layout)
        self._turns = route_turns(world.layout.routes)
        steps = int(round(self.config.horizon / world.dt))
        self._decay = (1.0 - self.config.speed_gain * world.dt) ** np.arange(
            -steps, steps + 1, dtype=float
        )
        # the defensive kernel's tables: route pairs where the first turns across the second
        n_routes = len(self._turns[0])
        ra, rb = np.meshgrid(np.arange(n_routes), np.arange(n_routes), indexing="ij")
        self._across = np.ascontiguousarray(turns_across(*self._turns, ra, rb))
        cfg, k = self.config, len(self.fractions)
        # an uncontrolled agent holds its speed 0 … period steps, then brakes at its limit
        self._hold_wild = np.rint(np.linspace(0, cfg.period, k)).astype(np.int64)
        self._ints = np.array(
            [
                cfg.period,
                steps,
                int(round(GIVE_WAY_HORIZON / world.dt)),
                cfg.sample_every,
                int(round(GIVE_WAY_LOOK_AHEAD / PATH_SPACING)),
            ],
            dtype=np.int64,
        )
        self._floats = np.array(
            [
                world.dt,
                cfg.max_accel,
                cfg.max_decel,
                cfg.speed_gain,
                cfg.margin,
                cfg.pedestrian_margin,
                cfg.lateral_accel,
                PATH_SPACING,
                STATIONARY_SPEED,
            ]
        )

    def plan_stepwise(
        self, world: World, uncontrolled: np.ndarray | None = None, choose=plan_choice
    ) -> np.ndarray:
        """`plan` through its steps, one Python call each (`allowed_speed`,
        `project`, `domains`, `defensive_domains`, `conflicts`, then
        `choose`, called as `csp_kernels.plan_choice`). Slower; it equals `plan`
        bit for bit (tested), and is where the tests and `bench_planner_kernels.py` see each
        kernel's inputs."""
        self._bind(world)
        out = np.zeros(world.n)
        agents = world.active.nonzero()[0]
        if not len(agents):
            return out
        targets = self.allowed_speed(world, agents)[:, None] * self.fractions[None, :]
        s_proj = self.project(world, agents, targets)
        allowed, hold = self._domains_and_hold_lines(world, agents, s_proj, uncontrolled)
        if uncontrolled is not None and uncontrolled[agents].any():
            allowed &= self.defensive_domains(world, agents, targets, uncontrolled[agents], hold)
        pairs, conflict = self.conflicts(world, agents, s_proj)
        choice, solved = choose(
            agents, world.s, world.offset, self._front, world.route,
            world.layout.routes.enter_s, allowed, pairs, conflict,
        )  # fmt: skip
        if not solved:
            raise RuntimeError("velocity CSP has no solution; the all-stop invariant is broken")
        out[agents] = targets[np.arange(len(agents)), choice]
        return out

    def plan(self, world: World, uncontrolled: np.ndarray | None = None) -> np.ndarray:
        """Target velocity (m/s) of every agent; 0 for inactive ones. `uncontrolled` (bool,
        (N,)) marks agents that may not follow the plan; the others drive defensively toward
        them (`defensive_domains`).

        The steps are `plan_stepwise`'s, run as two compiled calls
        (`.plan_kernels`)."""
        self._bind(world)
        out = np.zeros(world.n)
        agents = world.active.nonzero()[0]
        if not len(agents):
            return out
        defensive = uncontrolled is not None
        if not defensive:
            uncontrolled = self._none_uncontrolled
        routes, lights, cw, cfg = world.layout.routes, world.lights, self._crosswalks, self.config
        targets, s_proj, allowed, first, second, gaps = plan_head(
            agents, uncontrolled, self.fractions,
            world.state, world.s, world.offset, self._front, world.is_car, world.active,
            world.width, world.route, world.entered, world.max_speed, self._brake_limit,
            routes.curvature, routes.speed_limit, routes.enter_s, routes.light, routes.stop_s,
            self._across, world.light_state, lights.ends, lights.cycle, lights.offset,
            world.time, cw.centre, cw.axis, cw.half, cw.car_enter, cw.walk_crosswalk,
            cw.walk_enter, self._turns[1], self._offs32, self._radius, self._reach,
            world.path_c64, world.path_dir, self._decay, self._hold_wild, self._ints,
            self._floats, CURVE_LOOK_AHEAD, cfg.yield_to_pedestrians, defensive,
        )  # fmt: skip
        solved = plan_tail(
            agents, targets, s_proj, allowed, first, second, np.abs(gaps),  # numpy's abs
            world.state, world.s, world.offset, self._front, world.is_car, world.route,
            routes.enter_s, self._offs32, self._radius, self._reach, world.path_c64,
            world.path_dir, 1.0 / PATH_SPACING, cfg.margin, cfg.pedestrian_margin, out,
        )  # fmt: skip
        if not solved:  # cannot happen (all-stop is feasible); fail loudly if it does
            raise RuntimeError("velocity CSP has no solution; the all-stop invariant is broken")
        return out
