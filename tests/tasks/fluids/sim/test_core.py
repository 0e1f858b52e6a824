"""Simulator core invariants: dynamics, lights, collisions, spawning, progress."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fluids_bench.tasks.fluids.sim.collision import find_collisions, find_collisions_strtree
from fluids_bench.tasks.fluids.sim.config import CarConfig, SceneConfig
from fluids_bench.tasks.fluids.sim.dynamics import integrate
from fluids_bench.tasks.fluids.sim.layout import four_way, t_junction
from fluids_bench.tasks.fluids.sim.lights import GO, STOP, LightProgram, look_up
from fluids_bench.tasks.fluids.sim.spawn import capacity, spawn
from fluids_bench.tasks.fluids.sim.world import World


def _world(**kw) -> World:
    w = World(SceneConfig(**kw))
    spawn(w, np.random.default_rng(0))
    return w


# ---------------------------------------------------------------------------- dynamics
def test_bicycle_drives_straight_without_steering():
    state = np.array([[0.0, 0.0, 0.3, 5.0]])
    params = np.array([[1500.0, 1.3, 1.4, 10.0]])
    new = integrate(state, np.array([[0.0, 1500.0]]), np.array([True]), params, 0.1)
    assert new[0, :2] == pytest.approx(5.0 * 0.1 * np.array([np.cos(0.3), np.sin(0.3)]))
    assert new[0, 3] == pytest.approx(5.0 + 1.0 * 0.1)  # v' = F / m


def test_bicycle_turns_on_the_kinematic_radius():
    """Constant steering: the centre of mass moves on a circle of radius l_r / sin(β)."""
    lf, lr, psi, v, dt = 1.3, 1.4, 0.3, 4.0, 0.001
    beta = np.arctan(lr / (lf + lr) * np.tan(psi))
    state = np.array([[0.0, 0.0, 0.0, v]])
    params = np.array([[1500.0, lf, lr, 10.0]])
    pts = []
    for _ in range(3000):
        state = integrate(state, np.array([[psi, 0.0]]), np.array([True]), params, dt)
        pts.append(state[0, :2].copy())
    pts = np.array(pts)
    # fit the circle's centre: it lies at distance R from every point
    radius = lr / np.sin(beta)
    centre = np.array([-radius * np.sin(beta), radius * np.cos(beta)])  # left of the start velocity
    assert np.hypot(*(pts - centre).T) == pytest.approx(radius, rel=2e-3)


def test_pedestrian_point_model_walks_in_its_direction():
    state = np.array([[1.0, 2.0, 0.0, 1.0]])
    new = integrate(
        state, np.array([[np.pi / 2, 0.5]]), np.array([False]), np.array([[1, 1, 1, 1.4]]), 0.1
    )
    assert new[0] == pytest.approx([1.0, 2.1, np.pi / 2, 1.05])


def test_speed_is_clipped_to_its_range():
    state = np.array([[0.0, 0.0, 0.0, 9.9], [0.0, 0.0, 0.0, 0.1]])
    ctrl = np.array([[0.0, 1e6], [0.0, -1e6]])
    new = integrate(
        state, ctrl, np.array([True, True]), np.array([[1500.0, 1.3, 1.4, 10.0]] * 2), 0.1
    )
    assert new[:, 3].tolist() == [10.0, 0.0]


# ---------------------------------------------------------------------------- lights
def test_lights_loop_through_their_phases():
    program = LightProgram(four_way().lights)
    cycle = program.cycle[0]
    for t in np.arange(0.0, 2 * cycle, 0.1):
        assert np.array_equal(program.states(t), program.states(t + cycle))


def test_crosswalks_show_white_only_while_their_road_is_red():
    spec = four_way()
    program = LightProgram(spec.lights)
    names = program.names
    for t in np.arange(0.0, program.cycle.max(), 0.1):
        s = dict(zip(names, program.states(t), strict=True))
        for arm in ("east", "west", "north", "south"):
            if s[f"cw_{arm}"] == GO:
                assert s[f"tl_{arm}"] == STOP, (t, arm)


def test_conflicting_approaches_are_never_green_together():
    program = LightProgram(four_way().lights)
    for t in np.arange(0.0, program.cycle.max(), 0.1):
        s = dict(zip(program.names, program.states(t), strict=True))
        ew = s["tl_east"] != STOP or s["tl_west"] != STOP
        ns = s["tl_north"] != STOP or s["tl_south"] != STOP
        assert not (ew and ns), t


def _states_reference(program: LightProgram, t: float) -> tuple[np.ndarray, list[float]]:
    """A light lookup as one clock's numpy code wrote it before `look_up` (codes, [lo, hi))."""
    phase_t = np.mod(t + program.offset, program.cycle)
    idx = (phase_t[:, None] >= program.ends).sum(axis=1)
    rows = np.arange(len(program))
    codes = program.codes[rows, idx]
    start = np.where(idx > 0, program.ends[rows, np.maximum(idx - 1, 0)], 0.0)
    return codes, [t - (phase_t - start).min(), t + program.time_to_change(t).min()]


@pytest.mark.parametrize("scale", [1.0, 0.7])
def test_a_batch_of_light_lookups_equals_each_lookup_alone(scale):
    """`look_up` of many clocks at once (a vector env's worlds) gives each clock the bits of
    its own lookup, and `LightProgram.states` those of the one-clock reference."""
    program = LightProgram(four_way().lights, scale)
    rng = np.random.default_rng(0)
    ends = program.ends[np.isfinite(program.ends)]
    times = np.concatenate([np.arange(0.0, 2 * program.cycle.max(), 0.1), ends, ends - 1e-9])
    times = np.round(times + rng.uniform(0, 1e-3, len(times)) * (rng.random(len(times)) < 0.5), 9)
    current = np.empty((len(times), len(program)), np.int8)
    valid = np.empty((len(times), 2))
    look_up(program.ends, program.codes, program.cycle, program.offset, times, current, valid)
    for k, t in enumerate(times.tolist()):
        codes, interval = _states_reference(program, t)
        assert np.array_equal(current[k], codes), t
        assert valid[k].tolist() == interval, t
        alone = LightProgram(four_way().lights, scale)
        assert np.array_equal(alone.states(t), codes), t
        assert alone._valid.tolist() == interval, t


# ---------------------------------------------------------------------------- collisions
@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000), layout=st.sampled_from(["four_way", "t_junction", "roundabout"])
)
def test_fast_collisions_equal_the_strtree_reference(seed, layout):
    w = _world(layout=layout, num_cars=10, num_pedestrians=6)
    rng = np.random.default_rng(seed)
    state = w.state.copy()
    state[:, 0] = rng.uniform(-15, 15, w.n)
    state[:, 1] = rng.uniform(-15, 15, w.n)
    state[:, 2] = rng.uniform(-np.pi, np.pi, w.n)
    active = rng.random(w.n) < 0.8
    args = (state, w.length, w.width, w.is_car, active, w.layout.drivable_tolerant)
    fast = find_collisions(*args, w.layout.tolerant_boundary_vertices)
    assert sorted(fast) == sorted(find_collisions_strtree(*args))


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    layout=st.sampled_from(["four_way", "t_junction", "roundabout"]),
    spread=st.sampled_from([0.3, 1.0, 3.0]),
)
def test_quick_on_road_test_never_hides_an_offroad_car(seed, layout, spread):
    """Cars knocked off their paths by up to ``spread`` m and rad: the world's clearance-based
    shortcut gives the same collisions as checking every car exactly."""
    w = _world(layout=layout, num_cars=10, num_pedestrians=6)
    rng = np.random.default_rng(seed)
    w.step(np.zeros((w.n, 2)))
    w.state[:, :3] += rng.uniform(-spread, spread, (w.n, 3))
    w._update_progress()
    vouched = w.surely_on_road() & w.is_car & w.active
    exact = find_collisions(
        w.state,
        w.length,
        w.width,
        w.is_car,
        w.active,
        w.layout.drivable_tolerant,
        w.layout.tolerant_boundary_vertices,
    )
    assert not {a for a, b, kind in exact if kind == "offroad"} & set(vouched.nonzero()[0].tolist())
    assert sorted((c.a, c.b, c.kind) for c in w._collisions()) == sorted(exact)
    if spread < 1.0:
        assert vouched[w.is_car & w.active].mean() > 0.5  # the shortcut does its job


def test_overlapping_cars_and_offroad_are_logged():
    w = _world(num_cars=3, num_pedestrians=0)
    w.state[1, :3] = w.state[0, :3] + [1.0, 0.0, 0.0]  # car 1 on top of car 0
    w.state[2, :2] = [30.0, 30.0]  # car 2 in a field
    w.step(np.zeros((w.n, 2)))
    kinds = {(c.a, c.b, c.kind) for c in w.log}
    assert (0, 1, "car-car") in kinds
    assert (2, -1, "offroad") in kinds
    assert w.collided[[0, 1, 2]].all()


# ---------------------------------------------------------------------------- spawning / progress
@pytest.mark.parametrize("layout", ["four_way", "t_junction", "roundabout"])
def test_spawns_never_overlap_at_capacity(layout):
    probe = World(SceneConfig(layout=layout, num_cars=1, num_pedestrians=0))
    cars, peds = capacity(probe)
    for seed in range(5):
        w = World(SceneConfig(layout=layout, num_cars=min(cars, 64), num_pedestrians=min(peds, 32)))
        spawn(w, np.random.default_rng(seed))
        assert w.active.all()
        w.step(np.zeros((w.n, 2)))  # at rest: nothing may collide
        assert not w.log, (layout, seed, w.log[:3])


def test_spawn_depends_only_on_the_generator():
    a, b = _world(num_cars=6, num_pedestrians=4), _world(num_cars=6, num_pedestrians=4)
    assert np.array_equal(a.state, b.state) and np.array_equal(a.route, b.route)


def test_progress_follows_the_path():
    w = _world(num_cars=1, num_pedestrians=0)
    s0 = w.s[0]
    heading = w.state[0, 2]
    for _ in range(10):  # roll straight along the (straight) entry lane at 5 m/s
        w.state[0, 3] = 5.0
        w.step(np.array([[0.0, 0.0]]))
    assert w.s[0] == pytest.approx(s0 + 5.0, abs=0.05)
    assert w.state[0, 2] == heading


def test_config_errors_name_the_field():
    with pytest.raises(ValueError, match="'num_pedestrians'"):
        SceneConfig(num_pedestrians=-2)
    with pytest.raises(ValueError, match="'max_steer'"):
        CarConfig(max_steer=3.0)
    with pytest.raises(ValueError, match="'layout'"):
        SceneConfig(layout="spaghetti")


def test_t_junction_routes_cover_its_three_arms():
    spec = t_junction()
    exits = {r.exit.split("_")[0] for r in spec.routes}
    assert exits == {"east", "west", "south"}


@pytest.mark.parametrize("layout", ["four_way", "t_junction", "roundabout"])
def test_route_rows_are_what_set_path_writes(layout):
    """follow_route copies the layout's cached rows: they equal set_path's, bit for bit."""
    world = _world(layout=layout, num_cars=2, num_pedestrians=0)
    table = world.layout.routes
    for r in range(len(table.names)):
        world.set_path(
            0, table.path[r], table.heading[r], float(table.length[r]),
            world.layout.route_clearance[r],
        )  # fmt: skip
        world.follow_route(1, r)
        for name in ("path_z", "path_heading", "path_clearance", "path_dir", "path_c64"):
            a, b = getattr(world, name)
            assert a.tobytes() == b.tobytes(), (layout, r, name)
        assert world.path_len[0] == world.path_len[1]
