"""FLUIDS as a fair benchmark: defensive background drivers and collision fault labels."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.tasks.fluids.sim.config import SceneConfig
from fluids_bench.tasks.fluids.sim.fault import FaultTracker
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor

LAYOUTS = ("four_way", "t_junction", "roundabout")


# ---------------------------------------------------------------- fault labels, constructed
def _world(cars: int, peds: int = 0, lights: bool = True) -> World:
    return World(SceneConfig(num_cars=cars, num_pedestrians=peds, lights=lights))


def _route(world: World, name: str) -> int:
    return world.layout.routes.names.index(name)


def _conflict_s(world: World, r0: int, r1: int) -> tuple[float, float]:
    """Arc lengths on routes r0 and r1 of the points where they come closest."""
    p0, p1 = world.layout.routes.path[r0], world.layout.routes.path[r1]
    d = np.hypot(*(p0[:, None, :] - p1[None, :, :]).transpose(2, 0, 1))
    i, j = np.unravel_index(np.argmin(d), d.shape)
    from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING

    return i * PATH_SPACING, j * PATH_SPACING


def _run_until_collision(world: World, tracker: FaultTracker, controls=None, steps=100):
    controls = np.zeros((world.n, 2)) if controls is None else controls
    for _ in range(steps):
        events = world.step(controls)
        tracker.update()
        if events:
            return tracker.annotate(events)
    raise AssertionError("no collision happened")


def _steer_until_collision(world: World, tracker: FaultTracker, speeds: np.ndarray, steps: int):
    """Every agent steered along its route by the supervisor's PID at ``speeds`` (m/s)."""
    pid = DrivingSupervisor(world).pid
    for _ in range(steps):
        controls, memory = pid.controls(world, speeds)
        pid.commit(memory)
        events = world.step(controls)
        tracker.update()
        if events:
            return tracker.annotate(events)
    raise AssertionError("no collision happened")


def test_rear_end_is_the_followers_fault():
    w = _world(2)
    r = _route(w, "east_in_0->west_out_0")
    w.place(1, r, 20.0, speed=0.0)
    w.place(0, r, 8.0, speed=6.0)
    (c,) = _run_until_collision(w, FaultTracker(w))
    assert c["kind"] == "car-car"
    assert c["at_fault"] == [0] and c["rule"] == "rear_end" and not c["cut_in"]


def test_leader_that_cuts_in_inside_braking_distance_is_flagged():
    w = _world(2)
    r = _route(w, "east_in_0->west_out_0")
    w.place(0, r, 4.0, speed=8.0)
    w.place(1, _route(w, "north_in_0->south_out_0"), 2.0)
    tracker = FaultTracker(w)
    for _ in range(10):  # car 0 drives alone for a second
        w.step(np.zeros((2, 2)))
        tracker.update()
    w.place(1, r, float(w.s[0]) + 7.0, speed=0.0)  # appears 2.5 m ahead of its bumper
    (c,) = _run_until_collision(w, tracker)
    assert c["at_fault"] == [0] and c["rule"] == "rear_end" and c["cut_in"]


def test_entering_against_a_red_light_is_the_entrants_fault():
    w = _world(2)  # at t = 0 east-west is green, north-south red
    north, east = _route(w, "north_in_0->south_out_0"), _route(w, "east_in_0->west_out_0")
    c0, c1 = _conflict_s(w, north, east)
    w.place(0, north, c0 - 12.0, speed=8.0)  # crosses its red stop line
    w.place(1, east, c1 - 12.0, speed=8.0)  # green
    (c,) = _run_until_collision(w, FaultTracker(w))
    assert c["at_fault"] == [0] and c["rule"] == "red_light"


def test_entering_an_occupied_junction_is_the_entrants_fault():
    w = _world(2, lights=False)
    north, east = _route(w, "north_in_0->south_out_0"), _route(w, "east_in_0->west_out_0")
    c0, c1 = _conflict_s(w, north, east)
    w.place(1, east, c1 - 3.5, speed=2.0)  # already in the junction
    w.place(0, north, c0 - 14.0, speed=8.0)  # enters later, fast enough to arrive together
    tracker = FaultTracker(w)
    assert w.entered[1] == 0 and w.entered[0] < 0  # the one record of zone entries
    (c,) = _run_until_collision(w, tracker)
    assert c["at_fault"] == [0] and c["rule"] == "entered_occupied"


def test_moving_into_a_stationary_car_is_the_movers_fault():
    w = _world(2, lights=False)
    north, east = _route(w, "north_in_0->south_out_0"), _route(w, "east_in_0->west_out_0")
    c0, c1 = _conflict_s(w, north, east)
    w.place(1, east, c1, speed=0.0)  # stopped across the north-south lane
    w.place(0, north, c0 - 10.0, speed=6.0)
    (c,) = _run_until_collision(w, FaultTracker(w))
    assert c["at_fault"] == [0] and c["rule"] == "moving_into_stationary"


def test_leaving_the_road_is_the_drivers_fault():
    w = _world(1)
    w.place(0, _route(w, "east_in_0->west_out_0"), 5.0, speed=8.0)
    controls = np.array([[0.7, 0.0]])  # full steering lock
    (c,) = _run_until_collision(w, FaultTracker(w), controls)
    assert c["kind"] == "offroad" and c["at_fault"] == [0] and c["rule"] == "offroad"


def test_rear_end_on_a_roundabout_ring_is_the_followers_fault():
    """ "In front" is measured along the follower's path, so a rear-end on the curved ring
    (where two cars 10 m apart differ in heading by more than 45°) is still a rear-end,
    and not a cut-in: the leader was on the ring ahead all along."""
    w = World(SceneConfig(layout="roundabout", num_cars=2, num_pedestrians=0))
    r = _route(w, "south_in_0->west_out_0")  # three quarters round the ring
    start = float(w.layout.routes.enter_s[r]) + 25.0  # on the ring
    w.place(1, r, start + 12.0, speed=0.0)
    w.place(0, r, start, speed=6.0)
    heading = w.state[:, 2]
    assert abs((heading[1] - heading[0] + np.pi) % (2 * np.pi) - np.pi) > np.pi / 4
    (c,) = _steer_until_collision(w, FaultTracker(w), np.array([6.0, 0.0]), steps=100)
    assert c["at_fault"] == [0] and c["rule"] == "rear_end" and not c["cut_in"]


def test_world_records_when_each_agent_entered_its_zone():
    w = _world(2, lights=False)
    north = _route(w, "north_in_0->south_out_0")
    enter = float(w.layout.routes.enter_s[north])
    w.place(0, north, enter - 10.0, speed=5.0)
    w.place(1, north, enter + 1.0)  # front already past the zone's start
    assert w.entered.tolist() == [-1, 0]
    steps = 0
    while w.entered[0] < 0:
        w.step(np.array([[0.0, 0.0], [0.0, 0.0]]))
        steps += 1
    front = w.route_s[0] + w.length[0] / 2
    assert w.entered[0] == steps and enter <= front < enter + 0.6
    w.place(0, north, enter - 10.0)
    assert w.entered[0] == -1  # a new placement starts outside again


# ---------------------------------------------------------------- defensive drivers
def _ego_policy(kind: str, rng: np.random.Generator, info: dict, step: int, stop_at: int):
    if kind == "stop":
        return info["supervisor_action"] if step < stop_at else np.zeros(1, np.float32)
    if kind == "crawl":
        return np.ones(1, np.float32)
    return rng.uniform(0.0, 10.0, 1).astype(np.float32)


def _defensive_env(layout: str, num_cars: int, num_pedestrians: int, **kwargs):
    """FLUIDS-v0 at the velocity level with defensive background drivers."""
    return gym.make(
        "FLUIDS-v0",
        layout=layout,
        num_cars=num_cars,
        num_pedestrians=num_pedestrians,
        action_level="velocity",
        defensive=True,
        **kwargs,
    )


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("kind", ["stop", "crawl", "random"])
@pytest.mark.parametrize("yields", [False, True])
def test_supervised_cars_never_rear_end_the_ego(layout, kind, yields):
    """A stopping, crawling or random-speed ego is never hit from behind by a supervised car
    (nor hit by one in any other way that is the supervised car's fault and no cut-in), with
    the defensive planner alone and with v1's whole planner (also yielding to walkers)."""
    env = _defensive_env(layout, 5, 2, yield_to_pedestrians=yields)
    for seed in range(3):
        rng = np.random.default_rng(seed)
        stop_at = int(rng.integers(0, 60))
        _, info = env.reset(seed=seed)
        for step in range(250):
            _, _, term, trunc, info = env.step(_ego_policy(kind, rng, info, step, stop_at))
            for c in info["collisions"]:
                ours = [i for i in c["at_fault"] if i != 0]
                assert not (ours and not c["cut_in"]), (layout, kind, seed, c)
            if term or trunc:
                break


def test_without_defensive_drivers_a_stopped_ego_is_rear_ended():
    """The measurement the option answers: v0's planner assumes the ego follows the plan."""
    hits = 0
    env = gym.make("FLUIDS-v0", action_level="velocity")
    for seed in range(8):
        env.reset(seed=seed)
        for _ in range(150):
            _, _, term, trunc, info = env.step(np.zeros(1, np.float32))
            hits += any(
                c["rule"] == "rear_end" and c["at_fault"] != [0] for c in info["collisions"]
            )
            if term or trunc:
                break
    assert hits > 0


def test_defensive_must_be_a_bool():
    with pytest.raises(ValueError, match="defensive"):
        gym.make("FLUIDS-v0", defensive="yes")


# ---------------------------------------------------------------- quasi-LIDAR v1
def _lidar_env(**kwargs):
    env = gym.make(
        "FLUIDS-v1",
        obs_type="qlidar",
        action_level="velocity",
        num_cars=0,
        num_pedestrians=kwargs.pop("num_pedestrians", 0),
        **kwargs,
    )
    env.reset(seed=0)
    return env


def _observe(env):
    u = env.unwrapped
    return u.observer.observe(u.world, u.np_random)


def test_qlidar_sees_a_red_stop_line_ahead_until_it_turns_green():
    env = _lidar_env()
    w = env.unwrapped.world
    route = _route(w, "south_in_0->north_out_0")  # red at t = 0, green from 17 s
    w.place(0, route, 20.0)
    stop_gap = float(w.layout.routes.stop_s[route]) - 20.0
    seen = []
    for _ in range(220):
        obs = _observe(env)
        colour = w.lights.describe_states(w.light_state)["tl_south"]
        seen.append(colour)
        if colour == "red":
            assert obs[0, 1] == 4 and obs[0, 0] == pytest.approx(stop_gap, abs=0.05)
        elif colour == "yellow":
            assert obs[0, 1] == 5
        else:
            assert obs[0, 1] not in (4, 5)  # green: the line is no obstacle
        env.step(np.zeros(1, np.float32))  # the ego waits
    assert "red" in seen and "green" in seen


def test_qlidar_v1_occupied_crosswalk_reads_as_pedestrian_and_goal_row():
    env = _lidar_env(num_pedestrians=1, lights=False)
    w = env.unwrapped.world
    obs = _observe(env)
    assert obs.shape == (65, 4) and env.observation_space.contains(obs)
    assert obs[64, 1] == 6  # the goal row: bearing of the next waypoint, ahead on a straight
    car = _route(w, "south_in_0->north_out_0")
    w.place(0, car, 16.0)
    assert _observe(env)[64, 2] == pytest.approx(0.0, abs=1e-6)
    assert 2 not in _observe(env)[:64, 1]
    # a walker in the middle of the crosswalk the ego drives over (ahead of it, to the side)
    walk = [i for i, n in enumerate(w.layout.routes.names) if n.startswith("walk_south")][0]
    w.place(1, walk, float(w.layout.routes.enter_s[walk]) + 2.0)
    obs = _observe(env)
    ped_rays = obs[:64][obs[:64, 1] == 2]
    assert len(ped_rays) > 3  # the whole crosswalk blocks rays, not just the walker
    assert obs[0, 1] == 2


def test_qlidar_v0_reading_is_unchanged_by_the_v1_option():
    v0 = gym.make("FLUIDS-v0", obs_type="qlidar", lidar_noise=0.1, lidar_dropout=0.1)
    v1 = gym.make(
        "FLUIDS-v0", obs_type="qlidar", lidar_noise=0.1, lidar_dropout=0.1, lidar_version=1
    )
    a, _ = v0.reset(seed=3)
    b, _ = v1.reset(seed=3)
    assert a.shape == (64, 4) and b.shape == (65, 4)
    same = b[:64, 1] < 4  # where v1 sees nothing new, the rays are v0's, noise included
    assert np.array_equal(a[same], b[:64][same])


# ---------------------------------------------------------------- the v1 ids (registry checks)
V1_IDS = ("FLUIDS-v1", "FLUIDS-Sensitivity-v1")


@pytest.mark.parametrize("env_id", V1_IDS)
def test_v1_ids_pass_check_env(env_id):
    import warnings

    from gymnasium.utils.env_checker import check_env

    env = gym.make(env_id, obs_type=["qlidar", "explicit"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message=".*symmetric and normalized.*")
        check_env(env.unwrapped, skip_render_check=True)


def _v1_rollout(env_id: str, seed: int, steps: int = 80):
    env = gym.make(
        env_id, obs_type="qlidar", lidar_noise=0.1, num_pedestrians=3, action_level="velocity"
    )
    rng = np.random.default_rng(seed)
    env.action_space.seed(seed)
    obs, info = env.reset(seed=seed)
    trace = [obs, info]
    for _ in range(steps):
        a = info["supervisor_action"]
        assert env.action_space.contains(a)
        assert np.array_equal(a, env.unwrapped.supervisor_action())
        assert np.array_equal(a, env.unwrapped.supervisor_action())  # a second call agrees
        if rng.random() < 0.3:
            a = env.action_space.sample()
        obs, r, term, trunc, info = env.step(a)
        trace += [obs, r, term, trunc, info]
        if term or trunc:
            break
    return env, trace


@pytest.mark.parametrize("env_id", V1_IDS)
def test_v1_ids_are_deterministic_and_pickle_mid_episode(env_id):
    import pickle

    from exact_compare import exactly_equal

    _, a = _v1_rollout(env_id, 5)
    _, b = _v1_rollout(env_id, 5)
    assert exactly_equal(a, b)
    env = gym.make(env_id, obs_type="qlidar", action_level="velocity")
    _, info = env.reset(seed=9)
    for _ in range(20):
        _, _, _, _, info = env.step(info["supervisor_action"])
    clone = pickle.loads(pickle.dumps(env))
    act = np.array([3.0], np.float32)
    for _ in range(30):
        out1, out2 = env.step(act), clone.step(act)
        assert exactly_equal(list(out1), list(out2))
        if out1[2] or out1[3]:
            break


@pytest.mark.parametrize("obey", [False, True])
def test_running_a_red_light_fails_the_episode_only_with_obey_lights(obey):
    env = gym.make(
        "FLUIDS-v1", action_level="velocity", num_cars=0, num_pedestrians=0, obey_lights=obey
    )
    env.reset(seed=0)
    w = env.unwrapped.world
    w.place(0, _route(w, "south_in_0->north_out_0"), 6.0)  # red for the first 17 s
    for _ in range(400):
        _, _, term, trunc, info = env.step(np.array([10.0], np.float32))
        if term or trunc:
            break
    assert info["ego_arrived"] and info["ego_ran_red_light"] and not info["collisions"]
    assert info["is_success"] is (not obey)


def test_turning_across_oncoming_traffic_is_the_turners_fault():
    w = _world(2, lights=False)
    left = _route(w, "east_in_0->south_out_0")  # from the east, turning left across
    straight = _route(w, "west_in_0->east_out_0")  # oncoming, straight on
    c0, c1 = _conflict_s(w, left, straight)
    w.place(0, straight, c1 - 10.0, speed=5.0)
    w.place(1, left, c0 - 10.0, speed=5.0)
    (c,) = _steer_until_collision(w, FaultTracker(w), np.full(2, 5.0), steps=60)
    assert c["at_fault"] == [1] and c["rule"] == "turn_yields"


@pytest.mark.parametrize("action_level", ["velocity", "control"])
def test_supervisor_succeeds_under_the_v1_rule(action_level):
    """The v1 success rule (arrive, no collision, no red light) is one the supervisor meets:
    a small seeded sample of the README's 200-episode baseline (200/200 there)."""
    env = gym.make("FLUIDS-v1", action_level=action_level)
    for seed in range(6):
        _, info = env.reset(seed=100_000 + seed)
        while True:
            _, _, term, trunc, info = env.step(info["supervisor_action"])
            if term or trunc:
                break
        assert info["is_success"] and not info["ego_ran_red_light"], seed


# ---------------------------------------------------------------- right of way
def _turn_across_oncoming(layout: str, d_ego: float, v_ego: float, back: float, v_turn: float):
    """A supervised car (1) about to turn left across an oncoming ego (0) that goes straight
    at a constant ``v_ego``: returns the collisions and whether the turner got through."""
    env = _defensive_env(layout, 1, 0, lights=False)
    env.reset(seed=0)
    u = env.unwrapped
    w = u.world
    straight, left = _route(w, "west_in_0->east_out_0"), _route(w, "east_in_0->south_out_0")
    conflict, _ = _conflict_s(w, straight, left)
    w.place(0, straight, conflict - d_ego, speed=v_ego)
    w.place(1, left, float(w.layout.routes.enter_s[left]) - back - w.length[1] / 2, speed=v_turn)
    u.faults = FaultTracker(w)
    u.supervisor.prepare(w)
    collisions = []
    for _ in range(120):
        _, _, term, trunc, info = env.step(np.array([v_ego], np.float32))
        collisions += info["collisions"]
        if collisions or term or trunc:
            break
    passed = w.route_s[1] > _conflict_s(w, left, straight)[0] + 5.0 or bool(w.reached[1])
    return collisions, passed


# starting gaps and speeds at which v1's planner before gap acceptance turned into the ego
@pytest.mark.parametrize("layout", ["four_way", "t_junction"])
@pytest.mark.parametrize(
    "d_ego, v_ego, back, v_turn",
    [(20, 5, 0.5, 3), (25, 5, 6, 6), (25, 7, 0.5, 6), (30, 7, 3, 6), (40, 7, 0.5, 0)],
)
def test_a_supervised_car_turns_across_an_oncoming_ego_only_through_a_gap(
    layout, d_ego, v_ego, back, v_turn
):
    """Gap acceptance: the turner stops short of the ego's path or clears it before the ego
    (which keeps its speed: it has the right of way) gets there; never stops inside it."""
    collisions, _ = _turn_across_oncoming(layout, d_ego, v_ego, back, v_turn)
    assert collisions == [], collisions


def test_a_supervised_car_turns_in_front_of_a_distant_or_slow_ego():
    """Giving way is not freezing: with a clear gap the turner goes first."""
    collisions, passed = _turn_across_oncoming("four_way", 40, 3, 0.5, 3)
    assert collisions == [] and passed


@pytest.mark.parametrize("seed", [3013, 3182])
def test_circulating_cars_give_way_to_a_crawler_that_entered_the_roundabout_first(seed):
    """A 1 m/s ego creeping into the ring from inside the junction has the right of way over
    a car that entered after it; before giving way, these seeds ended in the circulating
    car's fault at step 114."""
    env = _defensive_env("roundabout", 2, 0, yield_to_pedestrians=True)
    env.reset(seed=seed)
    for _ in range(250):
        _, _, term, trunc, info = env.step(np.ones(1, np.float32))
        for c in info["collisions"]:
            assert c["at_fault"] == [0], c
        if term or trunc:
            break


def test_a_left_turn_yields_to_an_oncoming_right_turn_into_the_same_exit():
    w = _world(2, lights=False)
    right, left = _route(w, "east_in_0->north_out_0"), _route(w, "west_in_0->north_out_0")
    c0, c1 = _conflict_s(w, left, right)
    w.place(0, right, c1 - 10.0, speed=5.0)
    w.place(1, left, c0 - 10.0, speed=5.0)
    (c,) = _steer_until_collision(w, FaultTracker(w), np.full(2, 5.0), steps=60)
    assert c["at_fault"] == [1] and c["rule"] == "turn_yields"


def test_supervised_followers_keep_the_distance_to_stop_behind_a_supervised_leader():
    """With an uncontrolled agent about, a supervised leader may have to brake at once, so its
    supervised follower only keeps speeds from which it could still stop behind it."""
    from fluids_bench.tasks.fluids.supervisor.velocity import VelocityPlanner

    w = _world(3, lights=False)
    lane = _route(w, "east_in_0->west_out_0")
    w.place(0, _route(w, "north_in_0->south_out_0"), 2.0)  # the ego, far from both
    w.place(1, lane, 16.0, speed=6.0)  # leader
    w.place(2, lane, 9.0, speed=6.0)  # follower, 7 m behind at the same speed
    planner = VelocityPlanner()
    planner._bind(w)
    agents = np.arange(3)
    targets = planner.allowed_speed(w, agents)[:, None] * planner.fractions[None, :]
    allowed = planner.defensive_domains(w, agents, targets, np.array([True, False, False]))
    assert allowed[2, 0] and not allowed[2, -1]  # the follower may not hold its speed
    assert allowed[1].all()  # nothing ahead of the leader


def test_a_turner_does_not_enter_a_crossing_it_would_have_to_stop_in():
    """Don't block the box: with a hold line (an occupied crosswalk) just past the oncoming
    ego's path, turning in front of the ego no longer counts as clearing it."""
    from fluids_bench.tasks.fluids.supervisor.velocity import VelocityPlanner

    w = _world(2, lights=False)
    straight, left = _route(w, "west_in_0->east_out_0"), _route(w, "east_in_0->south_out_0")
    conflict, turn_at = _conflict_s(w, straight, left)
    w.place(0, straight, conflict - 40.0, speed=3.0)  # the ego, far and slow
    w.place(1, left, float(w.layout.routes.enter_s[left]) + 2.0 - w.front[1], speed=5.0)
    planner = VelocityPlanner()
    planner._bind(w)
    agents, wild = np.arange(2), np.array([True, False])
    targets = planner.allowed_speed(w, agents)[:, None] * planner.fractions[None, :]
    free = planner.defensive_domains(w, agents, targets, wild)
    hold = np.array([np.inf, turn_at + 2.0])  # its front 2 m past the ego's path: across it
    boxed = planner.defensive_domains(w, agents, targets, wild, hold)
    assert free[1].all()  # through a clear gap it may go first
    assert boxed[1, 0] and not boxed[1, -1]


def test_walkers_wait_for_a_car_turning_out_of_the_junction_across_their_crosswalk():
    """A supervised left-turner inside the junction commits its exit crosswalk, however slow
    it is, so a walker stepping out does not strand it across the oncoming lane; an
    uncontrolled car (``turning_out`` unset for it) does not."""
    from fluids_bench.tasks.fluids.sim.crosswalks import committed_crosswalks, crosswalks_of

    w = _world(1, lights=False)
    left = _route(w, "east_in_0->south_out_0")
    enter = float(w.layout.routes.enter_s[left])
    exit_cw = np.isfinite(crosswalks_of(w.layout).car_enter[left]) & (
        crosswalks_of(w.layout).car_enter[left] > enter
    )
    w.place(0, left, enter + 1.0 - w.front[0], speed=0.5)  # inside, crawling
    assert (committed_crosswalks(w, w.front, np.ones(w.n, bool)) & exit_cw).any()
    assert not (committed_crosswalks(w, w.front, np.zeros(w.n, bool)) & exit_cw).any()
    w.place(0, left, enter - 20.0, speed=0.5)  # still on its approach
    assert not (committed_crosswalks(w, w.front, np.ones(w.n, bool)) & exit_cw).any()


# seeds of the 200-episodes-per-scene measurement (scripts/quality/defensive_driving.py) in which a
# supervised car was at fault, each fixed by a rule of the planner that has its own test
FAULT_SEEDS = [
    ("four_way", 6, 1, "random", 6263),  # left turn against an oncoming right turn
    ("four_way", 3, 2, "noisy", 3284),
    ("t_junction", 5, 0, "random", 5151),
    ("t_junction", 6, 0, "random", 6049),
    ("t_junction", 4, 3, "random", 4478),  # follower behind a leader braking for the ego
    ("t_junction", 6, 2, "random", 6346),
    ("four_way", 7, 0, "crawl", 7115),
    ("t_junction", 7, 1, "noisy", 7259),  # walkers wait for a car turning out of the box
    ("four_way", 4, 4, "random", 4435),
    ("four_way", 6, 4, "random", 6593),
    ("four_way", 7, 2, "random", 7252),
    ("t_junction", 7, 3, "random", 7420),
    ("roundabout", 6, 3, "random", 6423),
    ("roundabout", 7, 0, "random", 7168),  # a merging car slows for the ring (gap acceptance)
    ("four_way", 3, 4, "random", 3597),  # a walker does not step out as the light turns red
]


@pytest.mark.parametrize("layout, cars, peds, policy, seed", FAULT_SEEDS)
def test_seeds_that_once_ended_in_a_supervised_fault(layout, cars, peds, policy, seed):
    """The measurement's ego (same generator as the script) against v1's planner."""
    env = _defensive_env(layout, cars - 1, peds, yield_to_pedestrians=True)
    rng = np.random.default_rng(
        [seed, ("supervisor", "stop", "crawl", "random", "noisy").index(policy)]
    )
    rng.integers(0, 100)  # the script's stop time, unused by these policies
    _, info = env.reset(seed=seed)
    for step in range(400):
        if policy == "noisy":
            label = info["supervisor_action"]
            action = np.clip(label + rng.normal(0.0, 2.0, 1), 0.0, 10.0).astype(np.float32)
        else:
            action = _ego_policy(policy, rng, info, step, 0)
        _, _, term, trunc, info = env.step(action)
        for c in info["collisions"]:
            assert c["at_fault"] == [0] or c["cut_in"], (step, c)
        if term or trunc:
            break


# a DAgger ego's target speeds on FLUIDS-v1 seed 100189 (scripts/baselines/fluids_baselines.py), run
# length encoded: it stands at the junction's entry, then drives off without stopping
DAGGER_EGO_100189 = [
    (2.5, 35), (0.0, 8), (2.5, 1), (0.0, 126), (10.0, 7), (2.5, 1), (10.0, 3), (7.5, 3),
    (4.4, 16), (3.3, 5), (2.2, 10), (1.1, 2), (0.0, 29), (2.2, 3), (4.4, 19),
]  # fmt: skip


def test_a_left_turner_that_set_off_in_front_of_a_waiting_ego_does_not_stop_in_its_way():
    """A left-turner that went on while the oncoming ego (turning right into the same exit)
    stood still met it side by side at the merge when the ego drove off: no candidate kept
    the full clearance both ways, so none was pruned, and it sped up in front of the ego and
    then had to brake in its path (``turn_yields``, its fault). It now keeps to the
    candidates that at least do not touch the ego either way: it stops short of the merge."""
    env = gym.make("FLUIDS-v1", action_level="velocity")
    env.reset(seed=100189)
    for speed, repeat in DAGGER_EGO_100189:
        for _ in range(repeat):
            _, _, term, trunc, info = env.step(np.array([speed], np.float32))
            assert all(c["at_fault"] == [0] or c["cut_in"] for c in info["collisions"]), info
            assert not (term or trunc)


@pytest.mark.parametrize("yields", [False, True])
def test_walkers_do_not_step_out_on_a_white_light_about_to_turn_red(yields):
    """Crosswalk lights go from white straight to red; with ``yield_to_pedestrians`` (v1) a
    walker who would not reach the crosswalk before red holds at the kerb, as at a flashing
    "don't walk", instead of arriving at it just as it turns red (seed 3597 below)."""
    from fluids_bench.tasks.fluids.sim.lights import GO
    from fluids_bench.tasks.fluids.supervisor.velocity import (
        VelocityPlanner,
        VelocityPlannerConfig,
    )

    w = _world(1, peds=1)  # agent 1 is the walker
    walk = _route(w, "walk_north_l")
    light = int(w.layout.routes.light[walk])
    while not (w.light_state[light] == GO and w.lights.time_to_change(w.time)[light] < 1.0):
        w.step(np.zeros((w.n, 2)))
    w.place(1, walk, float(w.layout.routes.stop_s[walk]) - 1.5 - w.front[1], speed=1.0)
    planner = VelocityPlanner(VelocityPlannerConfig(yield_to_pedestrians=yields))
    planner._bind(w)
    stops = planner._light_stops(w, np.array([1]), w.front[1:])
    assert (stops is not None and np.isfinite(stops[0])) == yields
