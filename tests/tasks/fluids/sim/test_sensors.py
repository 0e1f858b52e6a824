"""Bird's-eye and quasi-LIDAR sensors on hand-built worlds with known answers.

The test world is the default four-way intersection (1 lane per direction, lights): the ego sits
in the junction on the west→east route, where the road runs on to the map's edge along both
axes, a car and a pedestrian are placed by writing their states directly. Statistical checks use
enough samples that each tolerance is at least 5 standard errors (stated where used), so they
fail by chance with probability well under 1e-6.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Point, Polygon

import fluids_bench  # noqa: F401  (registers the env ids)
from fluids_bench.tasks.fluids.sim.config import SceneConfig
from fluids_bench.tasks.fluids.sim.draw import COLOURS, LIGHT_COLOURS, static_layer
from fluids_bench.tasks.fluids.sim.layout.compiled import CAR
from fluids_bench.tasks.fluids.sim.lights import GO, STOP
from fluids_bench.tasks.fluids.sim.render import Renderer
from fluids_bench.tasks.fluids.sim.sensors.birdseye import BirdsEyeSensor
from fluids_bench.tasks.fluids.sim.sensors.qlidar import EDGE_HIT, LABELS, QLidarSensor, road_edges
from fluids_bench.tasks.fluids.sim.world import World

EGO_Y = -1.75  # the west→east lane's centre line (m)
CAR_COLOUR = np.array(COLOURS["car"])
EGO_COLOUR = np.array(COLOURS["ego"])


def _route(world: World, name: str) -> int:
    return world.layout.routes.names.index(name)


def make_world(ego_heading: float = 0.0, ego_speed: float = 1.0) -> World:
    """Ego at (0, -1.75) (junction centre, in its lane), one other car, one pedestrian; the
    other agents are parked far away (inactive) until a test places them."""
    world = World(SceneConfig(num_cars=2, num_pedestrians=1))
    world.place(0, _route(world, "west_in_0->east_out_0"), 43.0, speed=ego_speed)
    world.place(1, _route(world, "east_in_0->west_out_0"), 0.0)
    walk = int(world.layout.routes.walk_routes[0])
    world.place(2, walk, 0.0)
    world.state[0] = (0.0, EGO_Y, ego_heading, ego_speed)
    world.active[1:] = False
    return world


def put(world: World, agent: int, x: float, y: float, heading: float, speed: float) -> None:
    world.state[agent] = (x, y, heading, speed)
    world.active[agent] = True


# ----------------------------------------------------------------------------- quasi-LIDAR
def test_ray_angles_are_equally_spaced_without_duplicates():
    world = make_world()
    for m in (1, 4, 7, 64):
        s = QLidarSensor(world.layout, rays=m)
        np.testing.assert_allclose(s.offsets, 2 * np.pi * np.arange(m) / m)
        wrapped = np.round(np.mod(s.offsets, 2 * np.pi), 9)
        assert len(np.unique(wrapped)) == m  # no ray at both +180° and -180°
    np.testing.assert_allclose(
        QLidarSensor(world.layout, rays=4).offsets, [0, np.pi / 2, np.pi, 1.5 * np.pi]
    )


@pytest.mark.parametrize(
    ("ego_heading", "ray", "car_heading"), [(0.0, 0, 2.0), (0.3, 5, -1.0), (-2.5, 40, 0.7)]
)
def test_ray_at_known_car_reads_distance_label_angle_and_speed(ego_heading, ray, car_heading):
    world = make_world(ego_heading, ego_speed=1.0)
    sensor = QLidarSensor(world.layout, rays=64, max_range=30.0)
    bearing = ego_heading + 2 * np.pi * ray / 64
    centre = 8.0
    put(world, 1, centre * math.cos(bearing), EGO_Y + centre * math.sin(bearing), car_heading, 3.0)
    row = sensor.observe(world, np.random.default_rng(0))[ray]
    # the ray passes through the car's centre: it enters where the nearer of the two slabs ends
    rel = car_heading - bearing
    half = min(2.25 / max(abs(math.cos(rel)), 1e-12), 0.95 / max(abs(math.sin(rel)), 1e-12))
    assert row[0] == pytest.approx(centre - half, abs=1e-4)
    assert LABELS[int(row[1])] == "car"
    assert row[2] == pytest.approx(
        (car_heading - ego_heading + np.pi) % (2 * np.pi) - np.pi, abs=1e-5
    )
    assert row[3] == pytest.approx(3.0 - 1.0)


def test_ray_at_pedestrian_and_empty_ray():
    world = make_world()
    sensor = QLidarSensor(world.layout, rays=8, max_range=30.0)
    put(world, 2, 0.0, EGO_Y + 5.0, math.pi / 2, 1.2)  # straight left of the ego: ray 2 of 8
    obs = sensor.observe(world, np.random.default_rng(0))
    assert obs.dtype == np.float32 and obs.shape == (8, 4)
    assert obs[2, 0] == pytest.approx(5.0 - 0.3)
    assert LABELS[int(obs[2, 1])] == "pedestrian"
    assert obs[2, 2] == pytest.approx(math.pi / 2) and obs[2, 3] == pytest.approx(1.2 - 1.0)
    # straight ahead and behind run along the road to the map's edge: nothing within 30 m
    for k in (0, 4):
        np.testing.assert_array_equal(obs[k], [30.0, 0.0, 0.0, 0.0])


def _reference_ray(world, ego, origin, direction, max_range, bounds):
    """(distance, label) of the nearest hit along one ray, by shapely, the slow obvious way."""
    ray = LineString([origin, origin + max_range * direction])
    best, label = max_range, 0
    for j in np.flatnonzero(world.active):
        if j == ego:
            continue
        poly = Polygon(world.corners(np.array([j]))[0])
        hit = ray.intersection(poly)
        if not hit.is_empty:
            d = Point(origin).distance(hit)
            if d < best:
                best, label = d, 1 if world.kind[j] == CAR else 2
    x0, y0, x1, y1 = bounds
    for p in shapely.get_coordinates(ray.intersection(world.layout.drivable.boundary)):
        on_edge_of_map = min(abs(p[0] - x0), abs(p[0] - x1), abs(p[1] - y0), abs(p[1] - y1)) < 1e-6
        d = float(np.hypot(*(p - origin)))
        if not on_edge_of_map and d < best:
            best, label = d, EDGE_HIT
    return best, label


@pytest.mark.parametrize("seed", [1, 2])
def test_qlidar_matches_shapely_reference_in_live_scenes(seed):
    env = gym.make("FLUIDS-v0", num_cars=8, num_pedestrians=4)
    _, info = env.reset(seed=seed)
    sensor = QLidarSensor(env.unwrapped.world.layout, rays=48, max_range=25.0)
    for step in range(60):
        _, _, term, trunc, info = env.step(info["supervisor_action"])
        if term or trunc:
            break
        if step % 15:
            continue
        world = env.unwrapped.world
        obs = sensor.cast(world)
        x, y, th, _ = world.state[0]
        for k in range(sensor.rays):
            a = th + sensor.offsets[k]
            d, label = _reference_ray(
                world,
                0,
                np.array([x, y]),
                np.array([math.cos(a), math.sin(a)]),
                25.0,
                world.layout.bounds,
            )
            assert obs[k, 0] == pytest.approx(d, abs=1e-6), (seed, step, k)
            if d < 25.0 - 1e-6:
                assert obs[k, 1] == label, (seed, step, k)


def test_road_edges_skip_the_map_edge():
    world = make_world()
    edges = road_edges(world.layout)
    x0, y0, x1, y1 = world.layout.bounds
    ends = np.concatenate([edges.a, edges.a + edges.e])
    on_x = np.isclose(ends[:, 0], x0) | np.isclose(ends[:, 0], x1)
    on_y = np.isclose(ends[:, 1], y0) | np.isclose(ends[:, 1], y1)
    n = len(edges.a)
    both_on_map_edge = (on_x[:n] & on_x[n:]) | (on_y[:n] & on_y[n:])
    assert len(edges.a) > 10 and not both_on_map_edge.any()
    assert road_edges(world.layout) is edges  # cached per layout


def test_qlidar_noise_statistics():
    """λ_l = 0.25 (σ = 0.5) on rays with clean hits in [3, 27] m (clipping needs a > 5σ draw).
    Each estimate averages over ≥ 30,000 samples, so the standard error of the mean is
    ≤ 0.5 / sqrt(30000) ≈ 0.003 (tolerance 0.02) and of the variance ≤ 0.25 · sqrt(2/30000)
    ≈ 0.002 (tolerance 0.015)."""
    world = make_world(ego_heading=0.4)
    put(world, 1, 8.0, EGO_Y + 3.0, 0.5, 2.0)
    put(world, 2, -3.0, EGO_Y + 4.0, 2.0, 1.0)
    clean = QLidarSensor(world.layout, rays=64, max_range=30.0).cast(world)
    sensor = QLidarSensor(world.layout, rays=64, max_range=30.0, noise_var=0.25)
    rng = np.random.default_rng(123)
    obs = np.stack([sensor.observe(world, rng) for _ in range(2000)]).astype(np.float64)
    hits = (
        (clean[:, 1] > 0) & (clean[:, 0] > 3.0) & (clean[:, 0] < 27.0) & (np.abs(clean[:, 2]) < 1.5)
    )
    assert hits.sum() >= 15
    np.testing.assert_array_equal(
        obs[:, :, 1], np.broadcast_to(clean[:, 1], obs.shape[:2])
    )  # labels exact
    for col in (0, 2, 3):
        err = (obs[:, hits, col] - clean[hits, col]).ravel()
        assert err.size >= 30000
        assert abs(err.mean()) < 0.02, col
        assert err.var() == pytest.approx(0.25, abs=0.015), col


def test_qlidar_dropout_rate_and_empty_reading():
    """ε = 0.3 over 3,000 draws of the rays that hit something (≥ 45,000 rays): the standard
    error of the rate is ≤ sqrt(0.21 / 45000) ≈ 0.0022; tolerance 0.012."""
    world = make_world()
    put(world, 1, 6.0, EGO_Y + 2.0, 0.0, 2.0)
    clean = QLidarSensor(world.layout, rays=32, max_range=30.0).cast(world)
    hits = clean[:, 1] > 0
    sensor = QLidarSensor(world.layout, rays=32, max_range=30.0, noise_var=0.01, dropout=0.3)
    rng = np.random.default_rng(7)
    obs = np.stack([sensor.observe(world, rng) for _ in range(3000)])
    dropped = obs[:, hits, 1] == 0
    assert dropped.size >= 45000
    assert dropped.mean() == pytest.approx(0.3, abs=0.012)
    empty = obs[:, hits][dropped]
    np.testing.assert_array_equal(empty, np.broadcast_to([30.0, 0, 0, 0], empty.shape))
    low, high = sensor.bounds
    assert ((obs >= low) & (obs <= high)).all()


# ----------------------------------------------------------------------------- bird's-eye
def _pixel(affine, x, y) -> tuple[int, int]:
    u, v = affine @ (x, y, 1.0)
    return int(round(v)), int(round(u))


@pytest.mark.parametrize("frame", ["ego", "ego_rotated", "global"])
def test_birdseye_shows_known_car_and_ego_at_expected_pixels(frame):
    world = make_world(ego_heading=0.0)
    put(world, 1, 10.0, EGO_Y, 0.0, 0.0)  # 10 m ahead, same heading
    sensor = BirdsEyeSensor(world.layout, size=84, fov=42.0, frame=frame)
    img = sensor.observe(world, np.random.default_rng(0))
    assert img.shape == (84, 84, 3) and img.dtype == np.uint8
    if frame == "ego":  # 2 px/m, north up, ego centred at pixel (41.5, 41.5)
        car_px, ego_px = (41, 59), (41, 40)
    elif frame == "ego_rotated":  # the ego faces up: the car is 20 px above it
        car_px, ego_px = (23, 41), (43, 41)
    else:  # the whole 86 m layout: 84 / 86 px/m, origin at pixel (41.5, 41.5)
        ppm = 84 / 86
        car_px = (int(round(41.5 - EGO_Y * ppm)), int(round(41.5 + 9.5 * ppm)))
        ego_px = (car_px[0], 41)
    np.testing.assert_array_equal(img[car_px], CAR_COLOUR)
    np.testing.assert_array_equal(img[ego_px], EGO_COLOUR)
    # and the pixel maps agree with the sensor's own
    # the sensor's own world → pixel map puts the ego at the image centre in ego frames (the
    # north-up view is a crop moved by whole pixels: within half a pixel of it)
    if frame != "global":
        centre = sensor.view(world) @ (0.0, EGO_Y, 1.0)
        np.testing.assert_allclose(centre, [41.5, 41.5], atol=0.5 if frame == "ego" else 1e-9)


@pytest.mark.parametrize(("time", "state"), [(0.0, GO), (20.0, STOP)])
def test_birdseye_light_colour_at_stop_line(time, state):
    world = make_world()
    world.light_state = world.lights.states(time)  # as World.step sets it at that time
    sensor = BirdsEyeSensor(world.layout, size=128, fov=40.0, frame="ego")
    img = sensor.observe(world, np.random.default_rng(0))
    affine = sensor.view(world)
    spec = world.layout.spec
    lane = spec.lane("east_in_0")
    assert world.light_state[[li.name for li in spec.lights].index(lane.light)] == state
    expected = np.array(LIGHT_COLOURS[(False, state)])
    assert np.abs(img[_pixel(affine, *lane.centerline[-1])].astype(int) - expected).max() <= 12
    cw = next(c for c in spec.crosswalks if c.name == "cw_east")
    cw_state = world.light_state[[li.name for li in spec.lights].index(cw.light)]
    for end in (cw.start, cw.end):
        got = img[_pixel(affine, *end)].astype(int)
        assert np.abs(got - LIGHT_COLOURS[(True, int(cw_state))]).max() <= 12


def test_birdseye_static_layer_is_cached_and_read_only():
    world = make_world()
    a = BirdsEyeSensor(world.layout, 84, 40.0, "ego")
    b = BirdsEyeSensor(world.layout, 84, 40.0, "ego_rotated")
    assert a.layer is b.layer and not a.layer.image.flags.writeable
    hits = static_layer.cache_info().hits
    BirdsEyeSensor(world.layout, 84, 40.0, "ego")
    assert static_layer.cache_info().hits == hits + 1
    first = a.observe(world, np.random.default_rng(0))
    first[:] = 0  # the observation is a fresh array: scribbling on it changes nothing
    assert a.observe(world, np.random.default_rng(0)).any()


@pytest.mark.parametrize("size", [64, 200, 512])
def test_birdseye_sizes_and_route_drawn(size):
    world = make_world()
    img = BirdsEyeSensor(world.layout, size, 40.0, "ego").observe(world, np.random.default_rng(0))
    assert img.shape == (size, size, 3)
    ahead = img[size // 2 - 1 : size // 2 + 1, int(size * 0.8)]  # 12 m ahead on the route
    assert (np.abs(ahead.astype(int) - COLOURS["route"]).max(axis=-1) <= 40).any()


def test_birdseye_pixel_noise_statistics():
    """λ_p = 25 on pixels whose clean value is in [40, 215] (clipping needs a > 5σ draw). Noise
    is rounded to integers, which adds 1/12 to the variance. Over ≥ 200,000 samples the
    standard error of the mean is ≤ 5 / sqrt(2e5) ≈ 0.011 (tolerance 0.06) and of the variance
    ≤ 25 · sqrt(2 / 2e5) ≈ 0.08 (tolerance 0.45)."""
    world = make_world()
    put(world, 1, 10.0, EGO_Y, 0.0, 0.0)
    clean = BirdsEyeSensor(world.layout, 84, 40.0, "ego").observe(world, None).astype(int)
    sensor = BirdsEyeSensor(world.layout, 84, 40.0, "ego", noise_var=25.0)
    rng = np.random.default_rng(5)
    mid = (clean >= 40) & (clean <= 215)
    errs = np.concatenate(
        [(sensor.observe(world, rng).astype(int) - clean)[mid] for _ in range(30)]
    )
    assert errs.size >= 200_000
    assert abs(errs.mean()) < 0.06
    assert errs.var() == pytest.approx(25.0 + 1 / 12, abs=0.45)


def test_sensors_and_renderer_do_not_write_to_the_world():
    world = make_world()
    put(world, 1, 10.0, EGO_Y, 0.0, 0.0)
    put(world, 2, 0.0, 3.0, 1.0, 1.0)
    before = {k: v.copy() for k, v in vars(world).items() if isinstance(v, np.ndarray)}
    rng = np.random.default_rng(0)
    for frame in ("ego", "ego_rotated", "global"):
        BirdsEyeSensor(world.layout, 84, 40.0, frame, noise_var=4.0).observe(world, rng)
    QLidarSensor(world.layout, 64, 30.0, 0.1, 0.2).observe(world, rng)
    Renderer(world.layout).render(world)
    for k, v in before.items():
        np.testing.assert_array_equal(getattr(world, k), v, err_msg=k)
