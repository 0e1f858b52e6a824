"""Pedestrians' right of way on crosswalks (``yield_to_pedestrians``, on in the v1 ids): one
occupancy definition, supervised cars that wait, walkers that do not step out in front of a car
that can no longer stop, and the ego's yield check in ``info`` and in success."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.tasks.fluids.sim.config import SceneConfig
from fluids_bench.tasks.fluids.sim.crosswalks import crosswalks_of, occupied
from fluids_bench.tasks.fluids.sim.fault import FaultTracker
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor, SupervisorConfig
from fluids_bench.tasks.fluids.supervisor.velocity import VelocityPlannerConfig

CAR_ROUTE = "south_in_0->north_out_0"


def _world(peds: int = 1) -> World:
    return World(SceneConfig(num_cars=1, num_pedestrians=peds, lights=False))


def _entry_crossing(world: World, route: int) -> tuple[int, float, int]:
    """The crosswalk a car on ``route`` meets first, where its front reaches it, and a walk
    across that crosswalk."""
    cw = crosswalks_of(world.layout)
    c = int(np.argmin(cw.car_enter[route]))
    walk = int(np.flatnonzero(cw.walk_crosswalk == c)[0])
    return c, float(cw.car_enter[route, c]), walk


def _supervisor(world: World, yield_to_pedestrians: bool) -> DrivingSupervisor:
    velocity = VelocityPlannerConfig(yield_to_pedestrians=yield_to_pedestrians)
    return DrivingSupervisor(world, SupervisorConfig(velocity=velocity))


def test_every_car_route_meets_its_entry_and_exit_crosswalks_and_every_walk_one():
    for layout in ("four_way", "t_junction", "roundabout"):
        world = World(SceneConfig(layout=layout, num_cars=1, num_pedestrians=1))
        cw, routes = crosswalks_of(world.layout), world.layout.routes
        crossed = np.isfinite(cw.car_enter[routes.car_routes]).sum(axis=1)
        assert (crossed == 2).all(), layout
        assert (cw.walk_crosswalk[routes.walk_routes] >= 0).all(), layout
        assert np.isinf(cw.car_enter[routes.walk_routes]).all()
        # a walker's front reaches the crosswalk just past its kerb mark
        gap = cw.walk_enter[routes.walk_routes] - routes.enter_s[routes.walk_routes]
        assert ((gap >= 0) & (gap <= 0.5)).all(), layout


def test_occupancy_follows_the_walkers_disc():
    w = _world()
    route = w.layout.routes.names.index(CAR_ROUTE)
    c, _, walk = _entry_crossing(w, route)
    w.place(0, route, 2.0)
    kerb = float(crosswalks_of(w.layout).walk_enter[walk])
    front = float(w.width[1]) / 2
    w.place(1, walk, kerb - front - 0.6)  # on the pavement, short of the crosswalk
    assert not occupied(w).any()
    w.place(1, walk, kerb + 1.0)
    assert occupied(w)[c] and occupied(w).sum() == 1
    w.active[1] = False  # a walker who has left the scene occupies nothing
    assert not occupied(w).any()


@pytest.mark.parametrize("yield_to_pedestrians", [True, False])
def test_a_supervised_car_waits_for_a_walker_on_its_crosswalk(yield_to_pedestrians):
    w = _world()
    route = w.layout.routes.names.index(CAR_ROUTE)
    c, enter, walk = _entry_crossing(w, route)
    w.place(0, route, enter - 14.0, speed=5.0)  # 14 m short: room to stop
    w.place(1, walk, float(crosswalks_of(w.layout).walk_enter[walk]) + 0.5)
    sup, tracker = _supervisor(w, yield_to_pedestrians), FaultTracker(w)
    passed_while_occupied, crossed = False, False
    for _ in range(300):
        sup.step(w)
        tracker.update()
        front = float(w.route_s[0] + w.length[0] / 2)
        if front > enter + 1.0 and not crossed:
            crossed = True
            passed_while_occupied = bool(occupied(w)[c])
    assert crossed  # it drives on once the crosswalk is free (or at once, without the rule)
    assert bool(tracker.failed_to_yield[0]) is (not yield_to_pedestrians)
    assert passed_while_occupied is (not yield_to_pedestrians)


def test_a_walker_waits_at_the_kerb_for_a_car_too_close_to_stop():
    w = _world()
    route = w.layout.routes.names.index(CAR_ROUTE)
    c, enter, walk = _entry_crossing(w, route)
    kerb = float(crosswalks_of(w.layout).walk_enter[walk])
    w.place(0, route, enter - w.length[0] / 2 - 4.0, speed=8.0)  # 4 m short at 8 m/s
    w.place(1, walk, kerb - float(w.width[1]) / 2 - 0.3)  # standing at the kerb
    sup = _supervisor(w, True)
    targets = sup.planner.plan(w)
    assert targets[1] == 0.0 and targets[0] > 0.0  # the walker stops, the car drives on
    # without the rule the same walker is free to walk into the crosswalk
    assert _supervisor(w, False).planner.plan(w)[1] > 0.0
    tracker = FaultTracker(w)
    for _ in range(40):
        sup.step(w)
        tracker.update()
    assert not tracker.failed_to_yield[0] and not w.collided.any()


@pytest.mark.parametrize(
    "route_name, uncontrolled, waits",
    [
        ("east_in_0->south_out_0", False, True),  # a supervised left-turner: the walker waits
        ("east_in_0->south_out_0", True, False),  # the learner's ego: it must stop for walkers
        ("west_in_0->south_out_0", False, False),  # a right-turner strands nobody
    ],
)
def test_a_walker_waits_for_a_supervised_left_turner_inside_the_junction(
    route_name, uncontrolled, waits
):
    """A slow car inside the junction is not *too close to stop* for the exit crosswalk, but a
    walker stepping out would strand a left-turner across the oncoming lane."""
    w = _world()
    route = w.layout.routes.names.index(route_name)
    cw = crosswalks_of(w.layout)
    enter = float(w.layout.routes.enter_s[route])
    c = int(np.argmax(np.where(np.isfinite(cw.car_enter[route]), cw.car_enter[route], -1)))
    assert cw.car_enter[route, c] > enter + 5.0  # the exit crosswalk, across the junction
    walk = int(np.flatnonzero(cw.walk_crosswalk == c)[0])
    kerb = float(cw.walk_enter[walk])
    w.place(0, route, enter + 1.0 - float(w.front[0]), speed=0.5)  # inside, crawling
    w.place(1, walk, kerb - float(w.width[1]) / 2 - 0.3)  # standing at the kerb
    mask = np.array([uncontrolled, False])
    targets = _supervisor(w, True).planner.plan(w, mask if uncontrolled else None)
    assert bool(targets[1] == 0.0) is waits


@pytest.mark.parametrize(
    "walker_on, gap, flagged",
    [
        (True, 20.0, True),  # on the crosswalk while the car could still stop: must yield
        (False, 20.0, False),  # nobody on it
        (True, 6.0, False),  # out in front of a car already committed (6 m at 6 m/s)
    ],
)
def test_failed_to_yield_flags_a_car_that_could_have_stopped(walker_on, gap, flagged):
    w = _world()
    route = w.layout.routes.names.index(CAR_ROUTE)
    c, enter, walk = _entry_crossing(w, route)
    w.place(0, route, enter - w.length[0] / 2 - gap, speed=6.0)
    # the walker stands at the far end of the crosswalk, out of the car's lane
    cw = crosswalks_of(w.layout)
    far = float(cw.walk_enter[walk]) + 2 * cw.half[c, 0] - 0.6
    w.place(1, walk, far if walker_on else 0.0)
    tracker = FaultTracker(w)
    for _ in range(45):  # coasting at 6 m/s: the front passes the crosswalk's edge
        w.step(np.zeros((w.n, 2)))
        tracker.update()
    assert w.route_s[0] + w.length[0] / 2 > enter
    assert bool(occupied(w)[c]) is walker_on
    assert bool(tracker.failed_to_yield[0]) is flagged


@pytest.mark.parametrize("rule", [False, True])
def test_driving_onto_an_occupied_crosswalk_fails_the_episode_only_with_the_rule(rule):
    env = gym.make(
        "FLUIDS-v1",
        action_level="velocity",
        num_cars=0,
        num_pedestrians=1,
        lights=False,
        yield_to_pedestrians=rule,
    )
    env.reset(seed=0)
    w = env.unwrapped.world
    route = w.layout.routes.names.index(CAR_ROUTE)
    c, enter, walk = _entry_crossing(w, route)
    cw, routes = crosswalks_of(w.layout), w.layout.routes
    # a walker just stepped out at the far side of the crosswalk from the ego's lane
    lane = routes.path[route, int(enter / 0.5)]
    walks = np.flatnonzero(cw.walk_crosswalk == c)
    starts = [routes.path[r, int(cw.walk_enter[r] / 0.5) + 1] for r in walks]
    walk = int(walks[np.argmax([np.hypot(*(p - lane)) for p in starts])])
    w.place(0, route, enter - 20.0, speed=6.0)  # room to stop
    w.place(1, walk, float(cw.walk_enter[walk]) + 0.5)
    env.unwrapped.faults = FaultTracker(w)  # the tracker follows the placed agents
    for _ in range(400):
        _, _, term, trunc, info = env.step(np.array([6.0], np.float32))
        if term or trunc:
            break
    assert info["ego_arrived"] and info["ego_failed_to_yield"] and not info["collisions"]
    assert info["is_success"] is (not rule)


@pytest.mark.parametrize("layout", ["four_way", "t_junction", "roundabout"])
def test_the_supervisor_yields_and_succeeds_on_every_layout(layout):
    """A small seeded sample of the README's 200-episode table (busy crosswalks: 6 walkers)."""
    env = gym.make("FLUIDS-v1", action_level="velocity", layout=layout, num_pedestrians=6)
    for seed in range(3):
        _, info = env.reset(seed=100_000 + seed)
        while True:
            _, _, term, trunc, info = env.step(info["supervisor_action"])
            if term or trunc:
                break
        assert not info["ego_failed_to_yield"] and info["is_success"], (layout, seed)


def test_yield_to_pedestrians_must_be_a_bool():
    with pytest.raises(ValueError, match="yield_to_pedestrians"):
        gym.make("FLUIDS-v1", yield_to_pedestrians="yes")
    with pytest.raises(ValueError, match="yield_to_pedestrians"):
        VelocityPlannerConfig(yield_to_pedestrians=1)
