"""FLUIDS' four-level supervisor: CSP invariants, lights, PID tracking, OMPL recovery, quality."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import fluids_bench  # noqa: F401
from fluids_bench.tasks.fluids.sim.config import CarConfig, SceneConfig
from fluids_bench.tasks.fluids.sim.lights import STOP
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.episode import make_world, run_supervised
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor
from fluids_bench.tasks.fluids.supervisor.trajectory import REJOIN_AHEAD, RecoveryPlanner
from fluids_bench.tasks.fluids.supervisor.velocity import VelocityPlanner, VelocityPlannerConfig


# ---------------------------------------------------------------------------- velocity CSP
def test_all_stop_is_always_feasible_and_plans_are_deterministic():
    world = make_world(SceneConfig(num_cars=12, num_pedestrians=8), seed=5)
    planner = VelocityPlanner(VelocityPlannerConfig(period=1))
    sup = DrivingSupervisor(world)
    for _ in range(150):  # drive a while so that queues, turns and crossings occur
        plan = planner.plan(world)
        assert np.array_equal(plan, VelocityPlanner(VelocityPlannerConfig(period=1)).plan(world))
        assert (plan >= 0).all() and (plan[~world.active] == 0).all()
        sup.step(world)
    agents = world.active.nonzero()[0]
    planner._bind(world)
    targets = planner.allowed_speed(world, agents)[:, None] * planner.fractions
    s_proj = planner.project(world, agents, targets)
    _, conflict = planner.conflicts(world, agents, s_proj)
    assert not conflict[:, 0, 0].any()  # both braking never conflicts
    assert planner.domains(world, agents, s_proj)[:, 0].all()  # stopping is never pruned


def test_cars_do_not_enter_on_red():
    world = make_world(SceneConfig(num_cars=8, num_pedestrians=0), seed=3)
    sup = DrivingSupervisor(world)
    routes = world.layout.routes
    for _ in range(600):
        before = world.route_s + world.length / 2
        sup.step(world)
        after = world.route_s + world.length / 2
        light = routes.light[world.route]
        stop = routes.stop_s[world.route]
        crossed = (before <= stop) & (after > stop) & world.is_car & (light >= 0)
        for a in crossed.nonzero()[0]:
            assert world.light_state[light[a]] != STOP, f"car {a} entered on red at t={world.time}"


def test_velocity_projection_matches_the_pid_speed_law():
    world = make_world(SceneConfig(num_cars=5, num_pedestrians=2), seed=0)
    world.state[:, 3] = [0.0, 3.0, 8.0, 10.0, 5.0, 1.0, 0.5]
    planner = VelocityPlanner()
    planner._bind(world)
    agents = np.arange(world.n)
    targets = planner.allowed_speed(world, agents)[:, None] * planner.fractions
    s_proj = planner.project(world, agents, targets)
    cfg, v, travelled = planner.config, world.state[:, 3:4].repeat(5, 1), []
    for _ in range(int(round(cfg.horizon / world.dt))):  # the step-by-step law, for reference
        a = np.clip(cfg.speed_gain * (targets - v), -cfg.max_decel, cfg.max_accel)
        v_next = np.maximum(v + a * world.dt, 0.0)
        travelled.append(0.5 * (v + v_next) * world.dt)
        v = v_next
    ref = world.s[:, None, None] + np.moveaxis(
        np.cumsum(travelled, 0)[cfg.sample_every - 1 :: cfg.sample_every], 0, -1
    )
    assert np.allclose(s_proj, ref, atol=1e-9)


def test_planner_config_is_validated():
    with pytest.raises(ValueError, match="'fractions'"):
        VelocityPlannerConfig(fractions=(0.5, 1.0))
    with pytest.raises(ValueError, match="'period'"):
        VelocityPlannerConfig(period=0)


@pytest.mark.parametrize("field", ["lateral_accel", "speed_gain", "max_accel", "max_decel"])
@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), float("inf"), True, "2"])
def test_planner_dynamics_fields_are_validated(field, value):
    """They divide in the projection: max_decel = 0 used to divide by zero mid-episode."""
    with pytest.raises(ValueError, match=f"'{field}' is {value!r}"):
        VelocityPlannerConfig(**{field: value})


def test_priority_order_is_honoured_by_the_installed_solver():
    """The CSP reference (csp_reference.py) fixes python-constraint2's variable order by
    overriding the solver's getSortedVariables (no public API for it): the installed version
    must still consult it.
    The solver tries a domain's values from the end, so whichever variable comes first takes
    the larger value of a + b <= 1; the library's own order (most constraints first) would
    put "b" first here."""
    from constraint import FunctionConstraint, Problem
    from csp_reference import _PrioritySolver

    def solve(order):
        problem = Problem(_PrioritySolver(order))
        problem.addVariables(["a", "b", "c"], [0, 1])
        problem.addConstraint(FunctionConstraint(lambda a, b: a + b <= 1), ["a", "b"])
        problem.addConstraint(FunctionConstraint(lambda b, c: b + c <= 2), ["b", "c"])
        return problem.getSolution()

    assert solve(["a", "b", "c"]) == {"a": 1, "b": 0, "c": 1}
    assert solve(["b", "a", "c"]) == {"a": 0, "b": 1, "c": 1}


# ---------------------------------------------------------------------------- PID tracking
def test_pid_tracks_generated_trajectories():
    """ch. 7: the PID tracks over 99% of 200 generated trajectories. Ours: within 0.5 m laterally
    of every route of every layout, at random cruise speeds, through the turn."""
    rng = np.random.default_rng(0)
    layouts = [("four_way", 1), ("four_way", 2), ("t_junction", 1), ("roundabout", 1)]
    worst = []
    for i in range(200):
        layout, lanes = layouts[i % len(layouts)]
        car = CarConfig(max_speed=float(rng.uniform(3.0, 12.0)))
        world = World(
            SceneConfig(
                layout=layout, lanes=lanes, lights=False, num_cars=1, num_pedestrians=0, car=car
            )
        )
        route = int(rng.choice(world.layout.routes.car_routes))
        world.place(0, route, float(rng.uniform(12.0, 26.0)))
        sup = DrivingSupervisor(world)
        clear = world.layout.routes.clear_s[route] + 5.0
        err = 0.0
        while world.active[0] and world.s[0] < clear:
            sup.step(world)
            err = max(err, abs(world.lateral_error[0]))
        worst.append(err)
        assert not world.log
    assert np.mean(np.array(worst) <= 0.5) >= 0.99, sorted(worst)[-5:]


# ---------------------------------------------------------------------------- OMPL recovery
def _shoved_episode(seed: int):
    env = gym.make("FLUIDS-v0", num_cars=0, num_pedestrians=0, lights=False, max_episode_steps=800)
    _, info = env.reset(seed=seed)
    for _ in range(40):
        _, _, _, _, info = env.step(info["supervisor_action"])
    world = env.unwrapped.world
    heading = world.state[0, 2]
    left = np.array([-np.sin(heading), np.cos(heading)])
    world.state[0, :2] += 2.6 * left  # shoved into the oncoming lane, askew
    world.state[0, 2] += 0.4
    route = world.layout.routes
    nominal = route.path[world.route[0], : int(route.length[world.route[0]] / 0.5) + 1]
    trace, dist = [], []
    while True:
        _, _, term, trunc, info = env.step(info["supervisor_action"])
        trace.append(world.state[0].copy())
        dist.append(np.hypot(*(nominal - world.state[0, :2]).T).min())
        if term or trunc:
            return env.unwrapped, info, np.array(trace), np.array(dist)


def test_displaced_car_is_planned_back_by_ompl_and_rejoins():
    env, info, _, dist = _shoved_episode(seed=0)
    assert env.supervisor.recoveries >= 1  # a real OMPL Dubins plan was adopted
    assert dist[0] > 2.0
    rejoined = np.flatnonzero(dist < 0.3)
    assert len(rejoined) and (dist[rejoined[0] :] < 0.5).all()  # back on the route, and stays
    assert info["is_success"]


def test_via_pose_fallback_plans_a_valid_way_back():
    """A car on the two-lane four-way turned 130 degrees off its lane: no direct Dubins curve to
    any rejoin point stays on the road, so recovery takes two curves through a via pose. The
    adopted path starts at the car, reaches a rejoin point, follows the route to its end, the
    footprint stays in the drivable area along the bridge, and a second planner (as in another
    process) gives the same path bit for bit."""
    paths = []
    for _ in range(2):
        world = make_world(SceneConfig(num_cars=1, num_pedestrians=0, lanes=2), seed=0)
        world.state[0] = (3.2952288441078945, -26.642980601547176, -0.7361855607055166, 0.0)
        world.route_s[0] = 20.5
        planner = RecoveryPlanner(world)
        vias = []
        planner.via = lambda a, b, via=planner.via, vias=vias: vias.append(via(a, b)) or vias[-1]
        assert planner.plan(world, 0)
        assert vias and vias[-1] is not None  # the direct curves all failed
        assert world.recovering[0]
        routes, r = world.layout.routes, int(world.route[0])
        path = world.path[0, : int(round(world.path_len[0] / 0.5)) + 1]
        assert np.hypot(*(path[0] - world.state[0, :2])) < 0.5  # starts at the car
        rejoins = routes.path[r, [int(round((20.5 + a) / 0.5)) for a in REJOIN_AHEAD]]
        assert min(np.hypot(*(path[:, None] - rejoins).T).min(axis=0)) < 0.5  # reaches one
        assert np.hypot(*(path[-1] - routes.path[r, int(round(routes.length[r] / 0.5))])) < 1.0
        bridge = vias[-1]
        head = np.arctan2(*np.diff(bridge, axis=0).T[::-1])
        assert all(
            planner.valid(planner.state(x, y, h))
            for (x, y), h in zip(bridge[:-1], head, strict=True)
        )
        paths.append(path.copy())
    assert np.array_equal(paths[0], paths[1])


def test_recovery_is_deterministic():
    _, _, a, _ = _shoved_episode(seed=1)
    _, _, b, _ = _shoved_episode(seed=1)
    assert np.array_equal(a, b)


# ---------------------------------------------------------------------------- quality
@pytest.mark.parametrize(
    ("layout", "cars", "peds"),
    [("four_way", 7, 4), ("four_way", 4, 2), ("t_junction", 5, 3), ("roundabout", 5, 3)],
)
def test_everyone_supervised_reaches_their_goal(layout, cars, peds):
    """A CI-sized slice of the quality table (scripts/quality/supervisor_quality.py runs all of it)."""
    results = [
        run_supervised(SceneConfig(layout=layout, num_cars=cars, num_pedestrians=peds), seed)
        for seed in range(6)
    ]
    failures = [r.as_dict() for r in results if not r.success]
    assert not failures


# ---------------------------------------------------------------------------- OMPL nominal routes
@pytest.mark.parametrize("layout", ["four_way", "t_junction", "roundabout"])
def test_ompl_can_plan_every_route(layout):
    from fluids_bench.tasks.fluids.sim.layout import build_layout, compile_layout
    from fluids_bench.tasks.fluids.supervisor.trajectory import ompl_layout

    spec = build_layout(layout)
    base, planned = compile_layout(spec), ompl_layout(spec, CarConfig())
    cars = planned.routes.car_routes
    changed = [r for r in cars if not np.array_equal(planned.routes.path[r], base.routes.path[r])]
    assert len(changed) == len(cars)  # OMPL found a valid chain of Dubins curves for every route
    assert np.array_equal(
        planned.routes.path, ompl_layout.__wrapped__(spec, CarConfig()).routes.path
    )
    env = gym.make("FLUIDS-v0", layout=layout, trajectory_planner="ompl", max_episode_steps=1200)
    for seed in range(2):
        _, info = env.reset(seed=seed)
        while True:
            _, _, term, trunc, info = env.step(info["supervisor_action"])
            if term or trunc:
                break
        assert info["is_success"], (layout, seed)


def test_pedestrian_waits_for_a_car_already_in_the_crosswalk():
    """Crosswalk white, but a (slow) car is on the crosswalk across the walker's path: the car
    keeps its right of way and the walker waits at the kerb."""
    from fluids_bench.tasks.fluids.sim.lights import GO

    world = World(SceneConfig(num_cars=1, num_pedestrians=1, car=CarConfig(max_speed=0.5)))
    routes, lights = world.layout.routes, world.lights
    walk = routes.names.index("walk_west_r")
    white = next(
        t for t in np.arange(0, 60, 0.1) if lights.states(t)[lights.names.index("cw_west")] == GO
    )
    world.time, world.light_state = float(white), lights.states(white)
    world.place(0, routes.names.index("west_in_0->east_out_0"), 31.5)  # on the crosswalk
    world.place(1, walk, routes.enter_s[walk] - 0.3)  # at the kerb, about to cross
    plan = VelocityPlanner(VelocityPlannerConfig(period=1)).plan(world)
    assert plan[0] > 0 and plan[1] == 0
    world.place(0, routes.names.index("west_in_0->east_out_0"), 3.0)  # car far back: walk
    assert VelocityPlanner(VelocityPlannerConfig(period=1)).plan(world)[1] > 0
