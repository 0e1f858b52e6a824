"""The velocity planner's defensive constraints as the numpy formulation that
:func:`fluids_bench.tasks.fluids.supervisor.defensive_kernels.defensive_forbid` replaced
(the planner's methods as they were, taking the planner as ``self``): a reference for
``test_defensive_kernel.py``.

Their pairwise tables come from :func:`conflict_tables_of`, whole numpy arrays (the broad and
narrow phases of the planner's kernels in float32, as they compute them).
"""

from __future__ import annotations

import numpy as np

from fluids_bench.tasks.fluids.sim.fault import STATIONARY_SPEED, turns_across
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.kernels import hold_then_brake
from fluids_bench.tasks.fluids.supervisor.velocity import GIVE_WAY_HORIZON, GIVE_WAY_LOOK_AHEAD


def _relative(world: World, f: np.ndarray, ld: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Agent ``ld``'s position in agent ``f``'s frame (complex: along + 1j * across) and
    whether the two head within 45° of each other (agent indices, elementwise)."""
    th = world.state[f, 2]
    dth = (world.state[ld, 2] - th + np.pi) % (2 * np.pi) - np.pi
    return (world.position[ld] - world.position[f]) * np.exp(-1j * th), np.abs(dth) < np.pi / 4


def reference_defensive_domains(
    self,
    world: World,
    agents: np.ndarray,
    targets: np.ndarray,
    wild: np.ndarray,
    hold_lines: np.ndarray | None = None,
) -> np.ndarray:
    """Unary constraints toward uncontrolled agents: allowed[a, k] is False where supervised
    agent ``a``, holding candidate k until the next plan and braking then, could run into an
    uncontrolled agent (``wild``, positions in ``agents``) that brakes as hard as it can
    now or at any of a few later steps before the next plan (holding its speed until then).

    Pairs in which the uncontrolled agent follows the supervised one (within 45° of its
    heading, behind it) are skipped: a rear-end is the follower's fault. Braking now
    (candidate 0) is never pruned, so the CSP stays feasible.

    Toward an uncontrolled agent that has the right of way (:meth:`_right_of_way`), a
    supervised one also allows for it driving on: see :meth:`_give_way`, which needs the
    supervised agents' ``hold_lines`` (route arc lengths of the stop lines they will hold
    before, as :meth:`plan` finds them with the domains; default: none).
    """
    cfg, dt = self.config, world.dt
    allowed = np.ones(targets.shape, dtype=bool)
    tame = ~wild
    cars = world.is_car[agents]
    ii, jj = np.triu_indices(len(agents), k=1)
    pair = (wild[ii] != wild[jj]) & (cars[ii] | cars[jj])
    ii, jj = ii[pair], jj[pair]
    if not len(ii):
        return allowed
    # skip pairs where the uncontrolled agent is behind the supervised one, same way
    ahead, aligned = _relative(
        world, agents[np.where(wild[ii], ii, jj)], agents[np.where(wild[ii], jj, ii)]
    )
    follows = aligned & (ahead.real > 0)
    ii, jj = ii[~follows], jj[~follows]
    if not len(ii):
        return allowed
    k = targets.shape[1]
    steps = int(round(cfg.horizon / dt))
    v = world.state[agents, 3]
    hold = np.full(targets.shape, cfg.period, dtype=np.int64)
    # uncontrolled: hold the current speed for 0 … period steps, then brake at the limit.
    # (Guarding against every uncontrolled agent keeping its speed was tried: supervised
    # cars then hesitated so much that a supervisor-driven ego timed out in 1-2% of
    # episodes; _give_way does it only toward one with the right of way.)
    hold[wild] = np.rint(np.linspace(0, cfg.period, k)).astype(np.int64)
    goal = np.where(wild[:, None], v[:, None], targets)
    car = world.scene.car
    limit = np.where(
        world.is_car[agents],
        car.max_brake_force / world.params[agents, 0],
        world.scene.pedestrian.max_accel,
    )
    decel = np.where(wild, limit, cfg.max_decel)
    gain = np.where(wild, 1.0 / dt, cfg.speed_gain)
    s_def = hold_then_brake(
        world.s[agents],
        v,
        goal,
        hold,
        steps,
        cfg.sample_every,
        dt,
        cfg.max_accel,
        decel,
        gain,
    )
    # full clearance, not relaxed to the distance now: positions are path samples
    # (PATH_SPACING apart), so a relaxed check would let a car creep on, a rounding step
    # at a time, into an uncontrolled one already near it; braking is never pruned anyway
    conflict = conflict_tables_of(self, world, agents, s_def, ii, jj, relax=False)
    bad_i = conflict.any(axis=2)  # (P, K): candidate of ii against any scenario of jj
    bad_j = conflict.any(axis=1)
    forbid = np.zeros(targets.shape, dtype=bool)
    np.logical_or.at(forbid, ii[tame[ii]], bad_i[tame[ii]])
    np.logical_or.at(forbid, jj[tame[jj]], bad_j[tame[jj]])
    forbid |= _follow_supervised(self, world, agents, targets, wild, s_def)
    if hold_lines is None:
        hold_lines = np.full(len(agents), np.inf)
    give_way = _give_way(self, world, agents, targets, wild, ii, jj, hold_lines)
    # braking now is unsafe both ways (it cannot stop short of where the uncontrolled
    # agent may stop, and it would stop in the path of one that keeps going) while
    # going on clears that path: it clears the crossing rather than stop in it
    clear = forbid[:, 0] & give_way[:, 0]
    forbid[clear] = False
    forbid |= give_way
    forbid[:, 0] = False
    return allowed & ~forbid


def _follow_supervised(
    self, world: World, agents: np.ndarray, targets: np.ndarray, wild: np.ndarray, s_def
) -> np.ndarray:
    """forbid[a, k]: supervised follower a's candidate k (hold until the next plan, then
    brake) would run into the supervised car ahead of it in its lane if that one braked
    now: with uncontrolled agents about, a supervised leader may have to brake at once
    (its defensive constraints), which its followers' plans did not foresee."""
    forbid = np.zeros(targets.shape, dtype=bool)
    cars = world.is_car[agents] & ~wild
    idx = cars.nonzero()[0]
    if len(idx) < 2:
        return forbid
    a, b = np.meshgrid(idx, idx, indexing="ij")
    a, b = a.ravel(), b.ravel()
    keep = a != b
    f, ld = a[keep], b[keep]
    ahead, aligned = _relative(world, agents[f], agents[ld])
    behind = aligned & (ahead.real > 0) & (np.abs(ahead.imag) < 2.0)
    f, ld = f[behind], ld[behind]
    if not len(f):
        return forbid
    cfg, dt = self.config, world.dt
    # only the agents of those pairs are projected (positions in ``sub``)
    sub, pos = np.unique(np.concatenate([f, ld]), return_inverse=True)
    fs, ls = pos[: len(f)], pos[len(f) :]
    brake = s_def[sub]  # followers: hold their candidate until the next plan, then brake
    lead = np.unique(ls)
    on = agents[sub[lead]]
    brake[lead] = hold_then_brake(  # leaders: brake now
        world.s[on],
        world.state[on, 3],
        targets[sub[lead]],
        np.zeros((len(lead), targets.shape[1]), dtype=np.int64),
        s_def.shape[2] * cfg.sample_every,
        cfg.sample_every,
        dt,
        cfg.max_accel,
        np.full(len(lead), cfg.max_decel),
        np.full(len(lead), cfg.speed_gain),
    )
    conflict = conflict_tables_of(self, world, agents[sub], brake, fs, ls, relax=False)
    bad = conflict[:, :, 0]  # the leader braking now (its candidate 0 scenario)
    np.logical_or.at(forbid, f, bad)
    forbid[forbid.all(axis=1)] = False  # cannot help any more
    return forbid


def _right_of_way(self, world: World, agents: np.ndarray, t: np.ndarray, w: np.ndarray):
    """Whether uncontrolled ``w`` has the right of way over supervised ``t`` (positions in
    ``agents``, elementwise) by the rules that assign fault (:mod:`..sim.fault`): it
    entered its shared zone first (rule 7), or it comes the other way and goes straight
    while ``t`` turns across its path (rule 6)."""
    entered = world.entered[agents]
    first = (entered[w] >= 0) & ((entered[t] < 0) | (entered[w] < entered[t]))
    routes = world.route[agents]
    return first | turns_across(*self._turns, routes[t], routes[w])


def _give_way(
    self,
    world: World,
    agents: np.ndarray,
    targets: np.ndarray,
    wild: np.ndarray,
    ii: np.ndarray,
    jj: np.ndarray,
    hold_lines: np.ndarray,
) -> np.ndarray:
    """forbid[a, k]: True where supervised agent a's candidate k could run into an
    uncontrolled agent with the right of way over it that keeps going (a crawler
    creeping on into a roundabout, an oncoming car going straight through a left turn).

    A candidate is safe if, holding it until the next plan and then braking, the agent
    stops short of that agent's path, or if, holding it, it clears the path before that
    agent gets there (gap acceptance), whether that agent keeps its speed or speeds up (at
    the controller's acceleration, to the fastest speed allowed to it; one at rest is taken
    to stay there, so that a waiting ego and a waiting car do not deadlock). Both scenarios
    end at the agent's hold line (a red light, an occupied crosswalk): it does not enter
    a crossing that it would have to stop in (don't block the box).
    Everything is projected over :data:`GIVE_WAY_HORIZON`, long enough for a car turning
    from rest to clear a crossing, and the agent keeps a planning period to spare before
    it brakes. Where no candidate keeps the full clearance both ways, the candidates that
    at least do not touch that agent either way are kept; an agent with none at all (it is
    already in the way) is left as it is: stopping there would not help.
    """
    forbid = np.zeros(targets.shape, dtype=bool)
    t = np.where(wild[ii], jj, ii)
    w = np.where(wild[ii], ii, jj)
    row = _right_of_way(self, world, agents, t, w)
    if not row.any():
        return forbid
    # only the agents of those pairs are projected (positions in ``sub``)
    sub, pos = np.unique(np.concatenate([t[row], w[row]]), return_inverse=True)
    n = int(row.sum())
    ts, ws = pos[:n], pos[n:]
    cfg, dt = self.config, world.dt
    steps = int(round(GIVE_WAY_HORIZON / dt))
    s0, v, cand = world.s[agents[sub]], world.state[agents[sub], 3], targets[sub]
    decel = np.full(len(sub), cfg.max_decel)
    gain = np.full(len(sub), cfg.speed_gain)
    args = (steps, cfg.sample_every, dt, cfg.max_accel, decel, gain)
    hold = np.full(cand.shape, 2 * cfg.period, dtype=np.int64)  # a period to spare
    stop = hold_then_brake(s0, v, cand, hold, *args)
    hold[:] = steps
    # going on, it slows for the curves ahead (turning into a roundabout's ring)
    slowest = _slowest_ahead(self, world, agents[sub], GIVE_WAY_LOOK_AHEAD)
    go = hold_then_brake(s0, v, np.minimum(cand, slowest[:, None]), hold, *args)
    line = (hold_lines[sub] - world.offset[agents[sub]] - self._front[agents[sub]])[:, None, None]
    stop, go = np.minimum(stop, line), np.minimum(go, line)  # it stops at its hold line
    # the uncontrolled agent, if moving, keeps its speed or speeds up towards the fastest
    # speed allowed to it (its candidates' scenarios span the two); at rest, it stays
    moving = v > STATIONARY_SPEED
    faster = np.maximum(cand[:, -1] - v, 0.0)[:, None] * self.fractions[None, :]
    goal = np.where(moving[:, None], v[:, None] + faster, 0.0)
    wild_go = hold_then_brake(s0, v, goal, hold, *args)
    stop[ws], go[ws] = wild_go[ws], wild_go[ws]
    on = agents[sub]
    stop_fails = conflict_tables_of(self, world, on, stop, ts, ws, relax=False).any(axis=2)
    clear_fails = conflict_tables_of(self, world, on, go, ts, ws, relax=False).any(axis=2)
    np.logical_or.at(forbid, t[row], stop_fails & clear_fails)
    stuck = forbid.all(axis=1)
    if stuck.any():
        # no candidate keeps the full clearance both ways (a close pass counts, and a merge
        # is close): keep the candidates that at least do not touch that agent either way
        # (an agent taken to stay at rest that set off, met side by side at a merge)
        mine = stuck[t[row]]  # only the stuck agents' pairs
        ts_, ws_ = ts[mine], ws[mine]
        stop_t = conflict_tables_of(self, world, on, stop, ts_, ws_, relax=False, contact=True)
        go_t = conflict_tables_of(self, world, on, go, ts_, ws_, relax=False, contact=True)
        touch = np.zeros(targets.shape, dtype=bool)
        np.logical_or.at(touch, t[row][mine], stop_t.any(axis=2) & go_t.any(axis=2))
        forbid[stuck] = touch[stuck]
    forbid[forbid.all(axis=1)] = False  # no candidate helps: it is already in the way
    return forbid


def _slowest_ahead(self, world: World, agents: np.ndarray, metres: float) -> np.ndarray:
    """The lowest speed each of ``agents`` will be allowed over the next ``metres`` of its
    route (curves and speed limits), so that a projection held at it is not optimistic."""
    look = np.arange(0, int(round(metres / PATH_SPACING)) + 1)
    r, k = _path_ahead(world, agents, look)
    routes = world.layout.routes
    kappa = routes.curvature[r[:, None], k]
    curve = np.sqrt(self.config.lateral_accel / np.maximum(kappa, 1e-6))
    slowest = np.minimum(routes.speed_limit[r[:, None], k], curve).min(axis=1)
    return np.where(world.is_car[agents], np.minimum(world.max_speed[agents], slowest), np.inf)


def conflict_tables_of(
    self,
    world: World,
    agents: np.ndarray,
    s_proj: np.ndarray,
    ii: np.ndarray,
    jj: np.ndarray,
    relax: bool = True,
    contact: bool = False,
) -> np.ndarray:
    """conflict[p, a, b] (P, K, K) for the pairs (``ii[p]``, ``jj[p]``) of positions in
    ``agents`` projected to ``s_proj`` (A, K, T), as whole (P, K, K, T, 3, 3) numpy arrays.
    ``relax``: a pair already closer than its clearance conflicts only where it gets closer
    still; without it, wherever it stays inside the clearance. ``contact``: the clearance is
    the footprints' own (no margin)."""
    cars = world.is_car[agents]
    pts, dirs = world.path_samples(s_proj, agents)  # (A, K, T) complex64 each
    bound = self._reach[agents]
    pos = world.position[agents].astype(np.complex64)
    offs, radius = self._offs32[agents], self._radius[agents]
    now = pos[:, None] + offs * np.exp(1j * world.state[agents, 2]).astype(np.complex64)[:, None]
    d_now = np.abs(now[ii][:, :, None] - now[jj][:, None, :]).min(axis=(1, 2))
    crossing = ~cars & (
        world.route_s[agents] + self._front[agents]
        >= world.layout.routes.enter_s[world.route[agents]]
    )
    margin = np.where(
        crossing[ii] | crossing[jj], self.config.pedestrian_margin, self.config.margin
    )
    clearance = radius[ii] + radius[jj] + (0.0 if contact else margin)
    thresh = np.maximum(np.minimum(clearance, d_now - 0.05), 0.0) if relax else clearance
    reach2 = ((bound[ii] + bound[jj]) ** 2).astype(np.float32)
    # broad phase: swept boxes (every candidate, every time, and now) that do not overlap
    flat = np.concatenate([pts.reshape(len(agents), -1), pos[:, None]], axis=1)
    lo_x, hi_x = flat.real.min(1) - bound, flat.real.max(1) + bound
    lo_y, hi_y = flat.imag.min(1) - bound, flat.imag.max(1) + bound
    apart = (lo_x[ii] > hi_x[jj]) | (lo_x[jj] > hi_x[ii]) | (lo_y[ii] > hi_y[jj])
    apart |= lo_y[jj] > hi_y[ii]
    diff = pts[ii][:, :, None] - pts[jj][:, None, :]  # (P, K, K, T)
    near = diff.real**2 + diff.imag**2 < reach2[:, None, None, None]
    circles = pts[..., None] + offs[:, None, None, :] * dirs[..., None]  # (A, K, T, 3)
    dd = circles[ii][:, :, None, :, :, None] - circles[jj][:, None, :, :, None, :]
    d2 = (dd.real**2 + dd.imag**2).min(axis=(-2, -1))  # (P, K, K, T)
    hit = near & (d2 < (thresh * thresh)[:, None, None, None])
    return hit.any(axis=3) & ~apart[:, None, None]


def _path_ahead(world: World, agents: np.ndarray, look: np.ndarray):
    """Each agent's route (A,) and the indices (A, L) of its path samples ``look`` ahead."""
    k0 = np.rint(world.route_s[agents] / PATH_SPACING).astype(np.int64)
    last = world.layout.routes.path.shape[1] - 1
    return world.route[agents], np.minimum(np.maximum(k0[:, None] + look, 0), last)
