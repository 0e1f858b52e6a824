"""Layouts: every builder's geometry and route table is drivable and consistent, the layout file
format round-trips and rejects malformed files with errors that name the element and field.

Geometric invariants are checked with a car of 4.5 x 1.9 m whose centre follows each route (as
spawns place it: wholly on its path, so from half a car length after the start to half a car
length before the end).
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import fluids_bench
from fluids_bench.tasks.fluids.sim.collision import footprint_corners
from fluids_bench.tasks.fluids.sim.layout import (
    FORMAT_VERSION,
    Layout,
    LayoutSpec,
    build_layout,
    compile_layout,
    four_way,
    layout_from_dict,
    layout_to_dict,
    load_layout,
    roundabout,
    save_layout,
)
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING

CAR_LENGTH, CAR_WIDTH = 4.5, 1.9  # m
FOOTPRINT_STEP = 2.0  # m between checked car poses along a route
ROAD_TOLERANCE = 0.3  # m a footprint or walker may stand off its area
MAX_HEADING_STEP = 0.3  # rad between consecutive path samples
EXAMPLE = (
    Path(fluids_bench.__file__).parent / "tasks/fluids/sim/layout/examples/four_way_two_lane.json"
)

CASES = [
    (name, {"lanes": lanes, "lights": lights, "pedestrians": peds})
    for name in ("four_way", "t_junction")
    for lanes in (1, 2)
    for lights in (True, False)
    for peds in (True, False)
] + [("roundabout", {"pedestrians": True}), ("roundabout", {"pedestrians": False})]
CASE_IDS = [f"{n}-" + "-".join(f"{k}={v}" for k, v in kw.items()) for n, kw in CASES]


# ---------------------------------------------------------------- helpers


def _used(layout: Layout, r: int) -> int:
    """Number of samples of route ``r`` before its padding."""
    return int(round(layout.routes.length[r] / PATH_SPACING)) + 1


def _arm(lane_name: str) -> str:
    return lane_name.split("_")[0]


def _footprints(xy: np.ndarray, heading: np.ndarray) -> np.ndarray:
    """Car rectangles centred at ``xy`` (n, 2), long side along ``heading`` (n,)."""
    n = len(xy)
    corners = footprint_corners(
        xy[:, 0], xy[:, 1], heading, np.full(n, CAR_LENGTH), np.full(n, CAR_WIDTH)
    )
    return shapely.polygons(corners)


def _depth_off(area, polygon) -> float:
    """How far (m) the farthest point of ``polygon`` lies from ``area``."""
    pts = shapely.points(shapely.get_coordinates(shapely.segmentize(polygon, 0.05)))
    return float(shapely.distance(area, pts).max())


# ---------------------------------------------------------------- invariants of one layout


def check_car_paths_drivable(layout: Layout) -> None:
    area = layout.drivable.buffer(0.01)
    for r in layout.routes.car_routes:
        p = layout.routes.path[r, : _used(layout, r)]
        off = ~shapely.contains_xy(area, p[:, 0], p[:, 1])
        assert not off.any(), (layout.routes.names[r], p[off][:3])


def check_car_footprints_drivable(layout: Layout) -> None:
    area = layout.drivable.buffer(ROAD_TOLERANCE)
    shapely.prepare(area)
    rt = layout.routes
    for r in rt.car_routes:
        s = np.arange(CAR_LENGTH / 2, rt.length[r] - CAR_LENGTH / 2 + 1e-9, FOOTPRINT_STEP)
        k = np.round(s / PATH_SPACING).astype(int)
        fp = _footprints(rt.path[r, k], rt.heading[r, k])
        off = ~shapely.contains(area, fp)
        if off.any():
            depth = [_depth_off(layout.drivable, f) for f in fp[off]]
            i = int(np.argmax(depth))
            pytest.fail(
                f"{rt.names[r]}: car footprint {depth[i]:.3f} m off the drivable area at "
                f"s={s[off][i]:.1f} m (tolerance {ROAD_TOLERANCE} m); off at s={s[off].tolist()}"
            )


def check_routes_join_lane_ends(layout: Layout) -> None:
    spec, rt = layout.spec, layout.routes
    for r, route in zip(rt.car_routes, spec.routes, strict=True):
        entry, exit_ = spec.lane(route.entry), spec.lane(route.exit)
        p = rt.path[r, : _used(layout, r)]
        np.testing.assert_allclose(p[0], entry.centerline[0], atol=1e-9, err_msg=route.name)
        # resampling drops the last remainder under one spacing
        assert np.hypot(*(p[-1] - exit_.centerline[-1])) < PATH_SPACING + 1e-9, route.name
        lane_len = float(np.sum(np.hypot(*np.diff(np.asarray(entry.centerline), axis=0).T)))
        k = int(round(lane_len / PATH_SPACING))  # the entry lane's end (its stop line)
        assert np.hypot(*(p[k] - entry.centerline[-1])) < PATH_SPACING, route.name
        assert rt.clear_s[r] <= rt.length[r] + PATH_SPACING, route.name


def check_signalised_routes(layout: Layout) -> None:
    spec, rt = layout.spec, layout.routes
    for r, route in zip(rt.car_routes, spec.routes, strict=True):
        light = spec.lane(route.entry).light
        if light is None:
            assert rt.light[r] == -1 and rt.stop_s[r] == np.inf, route.name
            continue
        assert rt.light[r] >= 0 and spec.lights[rt.light[r]].name == light, route.name
        assert np.isfinite(rt.stop_s[r]) and 0 < rt.stop_s[r] < rt.clear_s[r], route.name


def check_headings_continuous(layout: Layout) -> None:
    rt = layout.routes
    for r in rt.car_routes:
        h = rt.heading[r, : _used(layout, r)]
        step = np.abs(np.angle(np.exp(1j * np.diff(h))))
        assert step.max() <= MAX_HEADING_STEP, (rt.names[r], float(step.max()), int(step.argmax()))


def check_walks_on_foot_areas(layout: Layout) -> None:
    area = shapely.union_all([layout.sidewalks, *layout.crosswalks]).buffer(ROAD_TOLERANCE)
    rt = layout.routes
    for r in rt.walk_routes:
        p = rt.path[r, : _used(layout, r)]
        off = ~shapely.contains_xy(area, p[:, 0], p[:, 1])
        assert not off.any(), (rt.names[r], p[off][:3])


def check_walk_crossing_marks(layout: Layout) -> None:
    rt, spec = layout.routes, layout.spec
    for r in rt.walk_routes:
        line = shapely.LineString(rt.path[r, : _used(layout, r)])
        crossed = [i for i, cw in enumerate(layout.crosswalks) if line.intersects(cw)]
        if not crossed:
            continue
        name = rt.names[r]
        assert np.isfinite(rt.enter_s[r]) and rt.enter_s[r] < rt.clear_s[r] <= rt.length[r], name
        light = spec.crosswalks[crossed[0]].light
        if light is None:
            assert rt.light[r] == -1, name
        else:
            assert spec.lights[rt.light[r]].name == light, name
            assert np.isfinite(rt.stop_s[r]) and rt.stop_s[r] < rt.clear_s[r], name


def check_movements_cover_arms(layout: Layout) -> None:
    """From every arm a car can reach every other arm; with one lane, from every lane."""
    spec = layout.spec
    arms = {_arm(lane.name) for lane in spec.lanes}
    one_lane = not any(lane.name.endswith("_in_1") for lane in spec.lanes)
    by_arm: dict[str, set[str]] = {}
    for entry in spec.entry_lanes:
        exits = [_arm(r.exit) for r in spec.routes_from(entry)]
        by_arm.setdefault(_arm(entry), set()).update(exits)
        if one_lane:
            assert sorted(exits) == sorted(arms - {_arm(entry)}), (entry, exits)
    assert by_arm == {a: arms - {a} for a in arms}, by_arm


CHECKS = [
    check_car_paths_drivable,
    check_car_footprints_drivable,
    check_routes_join_lane_ends,
    check_signalised_routes,
    check_headings_continuous,
    check_walks_on_foot_areas,
    check_walk_crossing_marks,
    check_movements_cover_arms,
]


def assert_valid(spec: LayoutSpec) -> None:
    layout = compile_layout(spec)
    for check in CHECKS:
        check(layout)


def assert_round_trips(spec: LayoutSpec) -> None:
    assert layout_from_dict(json.loads(json.dumps(layout_to_dict(spec)))) == spec


# ---------------------------------------------------------------- builders


@pytest.mark.parametrize("check", CHECKS, ids=lambda c: c.__name__.removeprefix("check_"))
@pytest.mark.parametrize(("name", "kwargs"), CASES, ids=CASE_IDS)
def test_builder_layout_is_valid(name, kwargs, check):
    check(compile_layout(build_layout(name, **kwargs)))


def test_layout_has_what_its_options_ask_for():
    for name, kwargs in CASES:
        layout = compile_layout(build_layout(name, **kwargs))
        spec = layout.spec
        arms = 3 if name == "t_junction" else 4
        assert len(spec.lanes) == 2 * arms * kwargs.get("lanes", 1)
        assert bool(spec.lights) == kwargs.get("lights", False)
        assert bool(spec.walks) == bool(spec.crosswalks) == kwargs["pedestrians"]
        assert (layout.sidewalks.area > 0) == kwargs["pedestrians"]
        assert len(layout.routes.car_routes) == len(spec.routes)


def test_compile_is_cached():
    a, b = four_way(lanes=2), four_way(lanes=2)
    assert a is not b and a == b
    assert compile_layout(a) is compile_layout(b)
    assert compile_layout(layout_from_dict(layout_to_dict(a))) is compile_layout(a)


def test_route_table_arrays_are_read_only():
    rt = compile_layout(four_way()).routes
    arrays = {k: v for k, v in vars(rt).items() if isinstance(v, np.ndarray)}
    assert {"path", "heading", "stop_s", "clear_s", "light", "entry"} <= set(arrays)
    for name, arr in arrays.items():
        assert not arr.flags.writeable, name
        with pytest.raises(ValueError, match="read-only"):
            arr.flat[0] = arr.flat[0]


_lengths = st.floats(10.0, 500.0)
_widths = st.floats(2.5, 5.0)
_speeds = st.floats(1.0, 40.0)
_times = st.floats(0.5, 300.0)


@settings(max_examples=15, deadline=None)
@given(
    name=st.sampled_from(["four_way", "t_junction"]),
    lanes=st.sampled_from([1, 2]),
    lights=st.booleans(),
    pedestrians=st.booleans(),
    lane_length=_lengths,
    lane_width=_widths,
    speed_limit=_speeds,
    green=_times,
    yellow=_times,
    all_red=_times,
)
def test_junction_builders_valid_over_their_ranges(name, **kwargs):
    spec = build_layout(name, **kwargs)
    assert_valid(spec)
    assert_round_trips(spec)


@settings(max_examples=15, deadline=None)
@given(
    radius=st.floats(8.0, 12.0),
    lane_width=st.floats(3.5, 5.0),
    pedestrians=st.booleans(),
    lane_length=_lengths,
    speed_limit=_speeds,
)
def test_roundabout_valid_near_its_defaults(**kwargs):
    spec = roundabout(**kwargs)
    assert_valid(spec)
    assert_round_trips(spec)


def test_roundabout_valid_over_its_range():
    @settings(max_examples=15, deadline=None, derandomize=True, phases=[Phase.generate])
    @given(radius=st.floats(8.0, 60.0), lane_width=_widths, pedestrians=st.booleans())
    def valid(**kwargs):
        assert_valid(roundabout(**kwargs))

    valid()


@pytest.mark.parametrize(
    "kwargs",
    [{"radius": 20.0}, {"radius": 40.0}, {"radius": 12.0, "lane_width": 2.5}],
    ids=["radius20", "radius40", "radius12-narrow"],
)
def test_roundabout_footprints_stay_on_road(kwargs):
    check_car_footprints_drivable(compile_layout(roundabout(**kwargs)))


# ---------------------------------------------------------------- file format


@pytest.mark.parametrize(("name", "kwargs"), CASES, ids=CASE_IDS)
def test_save_load_round_trip(tmp_path, name, kwargs):
    spec = build_layout(name, **kwargs)
    path = tmp_path / "layout.json"
    save_layout(spec, path)
    assert load_layout(path) == spec
    assert json.loads(path.read_text())["format_version"] == FORMAT_VERSION
    assert [p.name for p in tmp_path.iterdir()] == ["layout.json"]  # no temporary left behind
    assert_round_trips(spec)


def test_save_replaces_an_existing_file(tmp_path):
    path = tmp_path / "layout.json"
    save_layout(four_way(), path)
    save_layout(roundabout(), path)
    assert load_layout(path) == roundabout()


def test_shipped_example_is_the_two_lane_four_way():
    assert load_layout(EXAMPLE) == four_way(lanes=2), (
        f"{EXAMPLE} is stale: regenerate it with save_layout(four_way(lanes=2), path)"
    )


def test_toml_layout_loads(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(
        "format_version = 1\n"
        'name = "tiny"\n'
        "bounds = [-20, -20, 20, 20]\n"
        "[[lanes]]\n"
        'name = "in"\n'
        "centerline = [[-20, 0], [0, 0]]\n"
        "[[lanes]]\n"
        'name = "out"\n'
        "centerline = [[0, 0], [20, 0]]\n"
        "speed_limit = 8\n"
        "[[routes]]\n"
        'entry = "in"\n'
        'exit = "out"\n'
    )
    spec = load_layout(path)
    assert spec.lane("out").speed_limit == 8.0 and spec.lane("in").light is None
    assert_round_trips(spec)
    check_car_paths_drivable(compile_layout(spec))


def _set(*keys_value):
    *keys, value = keys_value

    def mutate(d):
        for k in keys[:-1]:
            d = d[k]
        d[keys[-1]] = value

    return mutate


def _delete(*keys):
    def mutate(d):
        for k in keys[:-1]:
            d = d[k]
        del d[keys[-1]]

    return mutate


# four_way(lanes=1): lanes are east_in_0, east_out_0, north_in_0, ...; routes[0] is east->north
MALFORMED = {
    "unknown field": (
        _set("lanes", 0, "widht", 3.0),
        "lanes[0] ('east_in_0'): unknown field 'widht'; "
        "allowed: centerline, light, name, speed_limit, width",
    ),
    "unknown top-level field": (_set("lane", []), "layout 'four_way': unknown field 'lane'"),
    "missing field": (
        _delete("lanes", 1, "centerline"),
        "lanes[1] ('east_out_0'): missing required field 'centerline'",
    ),
    "missing top-level field": (_delete("routes"), "missing required field 'routes'"),
    "bad value": (
        _set("lanes", 2, "width", -1),
        "lanes[2] ('north_in_0'): field 'width' is -1; allowed: a finite number > 0",
    ),
    "non-finite value": (_set("crosswalks", 1, "width", math.inf), "crosswalks[1] ('cw_north')"),
    "wrong type": (
        _set("lights", 0, "offset", "soon"),
        "lights[0] ('tl_east'): field 'offset' is 'soon'; allowed: a number",
    ),
    "bool is not a number": (_set("lanes", 0, "speed_limit", True), "field 'speed_limit'"),
    "short centerline": (
        _set("lanes", 3, "centerline", [[0, 0]]),
        "lanes[3] ('north_out_0'): field 'centerline'",
    ),
    "bad light state": (_set("lights", 0, "phases", [["blue", 3]]), "lights[0] ('tl_east')"),
    "dangling light reference": (
        _set("lanes", 0, "light", "tl_nowhere"),
        "lanes[0] ('east_in_0'): field 'light' is 'tl_nowhere'",
    ),
    "light of the wrong kind": (
        _set("crosswalks", 0, "light", "tl_east"),
        "crosswalks[0] ('cw_east'): field 'light' is 'tl_east'",
    ),
    "dangling lane reference": (
        _set("routes", 1, "exit", "nowhere"),
        "routes[1] ('east_in_0->nowhere'): field 'exit' is 'nowhere'; allowed: a lane of",
    ),
    "one via point": (_set("routes", 0, "via", [[1, 2]]), "routes[0] ('east_in_0->north_out_0')"),
    "non-finite via": (_set("routes", 0, "via", [[1, 2], [math.nan, 0]]), "field 'via'"),
    "duplicate name": (
        lambda d: d["lanes"].append(d["lanes"][0]),
        "field 'lanes' is ['east_in_0']; allowed: unique names",
    ),
    "element not an object": (_set("walks", 0, 7), "walks[0]: is 7"),
    "list not a list": (_set("lights", {}), "field 'lights' is {}; allowed: a list"),
    "bad bounds": (_set("bounds", [0, 0, 0]), "field 'bounds'"),
    "format version": (_set("format_version", 2), "field 'format_version' is 2; allowed: 1"),
    # limits and geometry (defect 5 of #10): refused at load, naming the element
    "bounds beyond the documented range": (
        _set("bounds", [-1e9, -1e9, 1e9, 1e9]),
        "field 'bounds' is (-1000000000.0, -1000000000.0, 1000000000.0, 1000000000.0); allowed: "
        "[xmin, ymin, xmax, ymax] within ±1000 m of the origin",
    ),
    "point far outside the bounds": (
        _set("lanes", 0, "centerline", [[46.5, 1.75], [5000.0, 1.75]]),
        "lanes[0] ('east_in_0'): field 'centerline' is (5000.0, 1.75); allowed: points within",
    ),
    "self-crossing lane": (
        _set("lanes", 0, "centerline", [[46.5, 1.75], [20, 1.75], [25, 6], [25, -3]]),
        "lanes[0] ('east_in_0'): field 'centerline' is ((46.5, 1.75), (20.0, 1.75), (25.0, 6.0), "
        "(25.0, -3.0)); allowed: a polyline that does not cross or touch itself",
    ),
    "route from an entry lane to an entry lane": (
        _set("routes", 0, "exit", "north_in_0"),
        "field 'exit' is 'north_in_0'; allowed: a lane no route starts from",
    ),
    "every lane on one segment": (
        lambda d: [lane.__setitem__("centerline", [[0, 0], [30, 0]]) for lane in d["lanes"]],
        "lanes[0] ('east_in_0'): field 'centerline' is ((0.0, 0.0), (30.0, 0.0)); allowed: a lane "
        "meeting others only at its edges; it overlaps lane",
    ),
    "no format version": (_delete("format_version"), "missing required field 'format_version'"),
    # physical limits: elements that load but no car or walker can use
    "zero-length lane": (
        _set("lanes", 0, "centerline", [[30, 1.75], [30, 1.75]]),
        "lanes[0] ('east_in_0'): field 'centerline'",
    ),
    "a 1e-9 m lane": (
        _set("lanes", 0, "centerline", [[30, 1.75], [30 + 1e-9, 1.75]]),
        "allowed: a path at least 0.5 m long",
    ),
    "zero-length crosswalk": (
        lambda d: d["crosswalks"][0].__setitem__("end", d["crosswalks"][0]["start"]),
        "crosswalks[0] ('cw_east'): field 'start/end'",
    ),
    "zero-length walk": (
        lambda d: d["walks"][0].__setitem__("waypoints", [d["walks"][0]["waypoints"][0]] * 2),
        "walks[0]",
    ),
    "tiny width": (_set("lanes", 2, "width", 1e-300), "allowed: a number of metres in [0.5, 50]"),
    "huge width": (_set("crosswalks", 0, "width", 1e9), "allowed: a number of metres in [0.5, 50]"),
    "huge speed limit": (_set("lanes", 0, "speed_limit", 1e300), "allowed: a number in (0, 50]"),
    # issue #44: refused at load, naming the field (a raw GEOSException or silently accepted)
    "huge curb radius": (
        _set("curb_radius", 1e300),
        "layout 'four_way': field 'curb_radius' is 1e+300; allowed: a number of metres in (0, ",
    ),
    "curb radius beyond the layout": (
        _set("curb_radius", 500),
        "field 'curb_radius' is 500; allowed: a number of metres in (0, ",
    ),
    "a 1e-300 s light phase": (
        _set("lights", 0, "phases", [["green", 1e-300], ["red", 10]]),
        "lights[0] ('tl_east'): field 'phases duration' is 1e-300; allowed: a number of seconds",
    ),
    "a 1e300 s light phase": (
        _set("lights", 0, "phases", [["green", 1e300]]),
        "lights[0] ('tl_east'): field 'phases duration' is 1e+300",
    ),
    "a 1e300 s light offset": (
        _set("lights", 0, "offset", 1e300),
        "lights[0] ('tl_east'): field 'offset' is 1e+300; allowed: a number of seconds in",
    ),
    "a light far outside the bounds": (
        _set("lights", 0, "position", [1e300, 1e300]),
        "lights[0] ('tl_east'): field 'position' is (1e+300, 1e+300); allowed: points within",
    ),
    "self-intersecting area": (
        _set("areas", 1, [[0, 0], [10, 10], [10, 0], [0, 10]]),
        "layout 'four_way': field 'areas[1]' is ((0.0, 0.0), (10.0, 10.0), (10.0, 0.0), (0.0, "
        "10.0)); allowed: a simple polygon (this one: Self-intersection",
    ),
    "self-intersecting island": (
        _set("islands", [[[0, 0], [10, 10], [10, 0], [0, 10]]]),
        "field 'islands[0]'",
    ),
    "duplicate route": (
        lambda d: d["routes"].append(dict(d["routes"][0])),
        "field 'routes' is ['east_in_0->north_out_0']; allowed: each movement (entry->exit) once",
    ),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_layout_is_rejected_naming_element_and_field(tmp_path, case):
    mutate, expected = MALFORMED[case]
    d = layout_to_dict(four_way(lanes=1))
    mutate(d)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d))
    with pytest.raises(ValueError) as info:
        load_layout(path)
    message = str(info.value)
    assert message.startswith(f"{path}: "), message
    assert expected in message, message


def test_duplicate_json_keys_are_refused(tmp_path):
    text = json.dumps(layout_to_dict(four_way(lanes=1)))
    path = tmp_path / "twice.json"
    path.write_text(text.replace('"name": "four_way"', '"name": "four_way", "name": "other"', 1))
    with pytest.raises(ValueError, match="key 'name' appears twice") as info:
        load_layout(path)
    assert str(path) in str(info.value)


def test_deeply_nested_json_is_refused_with_a_value_error(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text(
        '{"format_version": 1, "name": "x", "bounds": ' + "[" * 100_000 + "]" * 100_000 + "}"
    )
    with pytest.raises(ValueError, match="nested too deeply") as info:
        load_layout(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    ("text", "where"),
    [('{\n  "format_version": 1,\n  "name": "x",,\n}', "line 3, column 15"), ("", "line 1")],
)
def test_bad_json_names_file_and_position(tmp_path, text, where):
    path = tmp_path / "broken.json"
    path.write_text(text)
    with pytest.raises(ValueError, match="invalid JSON") as info:
        load_layout(path)
    assert str(path) in str(info.value) and where in str(info.value)


def test_self_intersecting_area_is_rejected_at_load_not_at_compile():
    d = layout_to_dict(four_way())
    d["areas"][1] = [[0, 0], [10, 10], [10, 0], [0, 10]]  # a bow-tie
    with pytest.raises(ValueError, match=r"field 'areas\[1\]'.*a simple polygon"):
        layout_from_dict(d)


def test_an_island_over_the_junction_is_refused_naming_it_and_a_route():
    d = layout_to_dict(four_way())
    d["islands"] = [[[-15, -15], [15, -15], [15, 15], [-15, 15]]]  # the whole junction
    spec = layout_from_dict(d)
    with pytest.raises(ValueError, match=r"field 'islands\[0\]' covers route 'east_in_0->"):
        compile_layout(spec)
    assert compile_layout(roundabout()).spec.islands  # a roundabout's centre is an island


def test_the_largest_curb_radius_allowed_compiles():
    d = layout_to_dict(four_way())
    side = min(d["bounds"][2] - d["bounds"][0], d["bounds"][3] - d["bounds"][1])
    d["curb_radius"] = side / 4
    check_car_paths_drivable(compile_layout(layout_from_dict(d)))


def test_top_level_must_be_an_object():
    with pytest.raises(ValueError, match="layout: is"):
        layout_from_dict([1, 2])


# ---------------------------------------------------------------- mutations never crash the loader

_BASE_TEXTS = [
    json.dumps(layout_to_dict(four_way(lanes=1))),
    json.dumps(layout_to_dict(roundabout())),
]
_JSON = st.recursive(
    st.none()
    | st.booleans()
    | st.integers()
    | st.floats()
    | st.text(max_size=6)
    | st.sampled_from(["green", "white", "traffic", "east_in_0", "tl_east"]),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=6,
)


def _slots(node, out):
    """Every (container, key) in a JSON tree."""
    keys = list(node) if isinstance(node, dict) else range(len(node))
    for k in keys:
        out.append((node, k))
        if isinstance(node[k], dict | list):
            _slots(node[k], out)
    return out


@st.composite
def _mutated(draw):
    """A layout file's contents with one to three random edits (replace, delete, add, scale)."""
    d = json.loads(draw(st.sampled_from(_BASE_TEXTS)))
    for _ in range(draw(st.integers(1, 3))):
        slots = _slots(d, [])
        if not slots:
            break
        container, key = slots[draw(st.integers(0, len(slots) - 1))]
        op = draw(st.sampled_from(["replace", "delete", "add", "scale"]))
        value = container[key]
        if op == "replace":
            container[key] = draw(_JSON)
        elif op == "delete":
            del container[key]
        elif op == "add" and isinstance(container, dict):
            container[draw(st.text(max_size=6))] = draw(_JSON)
        elif op == "add":
            container.append(copy.deepcopy(value))
        elif isinstance(value, int | float) and not isinstance(value, bool):
            container[key] = value * draw(st.sampled_from([-1, 0, 0.5, 2, 1e300]))
    return d


def _load_and_compile(d) -> None:
    """A mutated layout loads and compiles, or one of the two raises a ValueError: never a raw
    error (a curb_radius of 1e300 was a GEOSException at compile)."""
    try:
        spec = layout_from_dict(d)
    except ValueError as err:
        assert str(err)
        return
    hash(spec)  # specs are hashable (compile_layout caches on them)
    assert_round_trips(spec)
    try:
        compile_layout(spec)
    except ValueError as err:  # only an island across a car route is refused at compile
        assert "field 'islands[" in str(err), str(err)


@settings(max_examples=60, deadline=None)
@given(d=_mutated())
def test_mutated_layout_loads_valid_or_raises_value_error(d):
    _load_and_compile(d)


@pytest.mark.fuzz_full
@settings(max_examples=600, deadline=None)
@given(d=_mutated())
def test_mutated_layout_loads_valid_or_raises_value_error_full(d):
    """The full run of the test above (tests/test_fuzz.py says how to run it)."""
    _load_and_compile(d)


_TEXT = json.dumps(json.loads(_BASE_TEXTS[0]), indent=1)


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    start=st.integers(0, len(_TEXT) - 1),
    size=st.integers(1, 20),
    insert=st.text('{}[],:"-.0123456789eEaNIfinty', max_size=3),
)
def test_mutated_layout_text_loads_valid_or_raises_value_error(tmp_path, start, size, insert):
    path = tmp_path / "mutated.json"
    path.write_text(_TEXT[:start] + insert + _TEXT[start + size :], encoding="utf-8")
    try:
        spec = load_layout(path)
    except ValueError as err:
        assert str(path) in str(err)
        return
    hash(spec)
