"""The FLUIDS world: struct-of-arrays state of every agent, one vectorised `step`.

Agent 0 is always the ego car; cars come first, pedestrians after. Each agent follows its own
copy of a path (its route's, or a recovery path planned back to it), stored resampled every
`PATH_SPACING` metres so that progress `s` (m along the path) indexes it directly.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from fluids_bench.tasks.fluids.sim import kernels
from fluids_bench.tasks.fluids.sim.collision import (
    covering_circles,
    find_collisions,
    footprint_corners,
)
from fluids_bench.tasks.fluids.sim.config import SceneConfig
from fluids_bench.tasks.fluids.sim.entry import Entry
from fluids_bench.tasks.fluids.sim.layout.compiled import CAR, PEDESTRIAN, Layout, compile_layout
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.sim.lights import LightProgram

GOAL_TOLERANCE = 0.5  # m between an arriving agent's front and the end of its path
RECOVERY_ROOM = 160  # extra path samples per agent, for recovery paths longer than the route
PROGRESS_WINDOW = (-3, 9)  # path samples searched around the last progress: 3 back, 8 ahead


class RouteRows(NamedTuple):
    """What `World.set_path` writes for each route of a layout (R rows of one width)."""

    z: np.ndarray  # (R, width) complex128 points
    heading: np.ndarray  # (R, width)
    clearance: np.ndarray  # (R, width)
    direction: np.ndarray  # (R, width) complex64 unit tangents
    c64: np.ndarray  # (R, width) complex64 points
    length: np.ndarray  # (R,) m


def _path_rows(path, heading, length, clearance, width):
    """One agent's path rows, `width` samples long (padded with the last sample): points,
    headings, clearances, unit tangents, single-precision points, and the length (m)."""
    m = min(len(path), width)
    z, h, c = np.empty(width, np.complex128), np.empty(width), np.empty(width)
    for row, values in ((z, path[:, 0] + 1j * path[:, 1]), (h, heading), (c, clearance)):
        row[:m] = values[:m]
        row[m:] = values[m - 1]
    return (
        z,
        h,
        c,
        np.exp(1j * h).astype(np.complex64),
        z.astype(np.complex64),
        min(length, (m - 1) * PATH_SPACING),
    )


@functools.lru_cache(maxsize=32)
def route_rows(layout: Layout, width: int) -> RouteRows:
    """Every route's `_path_rows` on `layout`, computed once per layout and width (a
    reset places every agent on a route: copying rows is cheaper than building them)."""
    table = layout.routes
    rows = [
        _path_rows(
            table.path[r],
            table.heading[r],
            float(table.length[r]),
            layout.route_clearance[r],
            width,
        )
        for r in range(len(table.names))
    ]
    stacked = RouteRows(*(np.array(column) for column in zip(*rows, strict=True)))
    for column in stacked:
        column.setflags(write=False)  # shared by every world on the layout
    return stacked


@dataclass(frozen=True)
class Collision:
    step: int
    a: int
    b: int  # -1 for offroad
    kind: str

    def as_dict(self) -> dict:
        return {"step": self.step, "a": self.a, "b": self.b, "kind": self.kind}


_TICKS: dict[float, np.ndarray] = {}


def clock_ticks(dt: float, steps: int) -> np.ndarray:
    """The clock of a world after k steps of `dt`, for k = 0 … at least `steps`, as
    `World.begin_step` advances it from 0 (read-only, cached per `dt`): a batch of
    worlds reads every world's new time from it in one operation, with the same bits."""
    ticks = _TICKS.get(dt)
    if ticks is None or len(ticks) <= steps:
        n = max(steps + 1, 2 * len(ticks) if ticks is not None else 1024)
        times, t = [0.0], 0.0
        for _ in range(n - 1):
            t = round(t + dt, 9)
            times.append(t)
        ticks = _TICKS[dt] = np.array(times)
        ticks.setflags(write=False)
    return ticks


class World:
    """All agents of one scene on one compiled layout. Mutated only by `step` and the
    placement methods; readers (sensors, renderers, supervisors) must not write to its arrays."""

    def __init__(self, scene: SceneConfig, layout: Layout | None = None) -> None:
        self.scene = scene
        self.layout = layout if layout is not None else compile_layout(scene.layout_spec())
        self.dt = scene.dt
        n_cars, n_peds = scene.num_cars, scene.num_pedestrians
        n = n_cars + n_peds
        self.n = n
        self.kind = np.array([CAR] * n_cars + [PEDESTRIAN] * n_peds, dtype=np.int8)
        self.is_car = self.kind == CAR
        car, ped = scene.car, scene.pedestrian
        self.length = np.where(self.is_car, car.length, 2 * ped.radius)
        self.width = np.where(self.is_car, car.width, 2 * ped.radius)
        self.max_speed = np.where(self.is_car, car.max_speed, ped.max_speed)
        # dynamics parameters [mass, l_f, l_r, max_speed]; pedestrians ignore the first three
        self.params = np.column_stack(
            [
                np.where(self.is_car, car.mass, 1.0),
                np.full(n, car.lf),
                np.full(n, car.lr),
                self.max_speed,
            ]
        )
        self.lights = LightProgram(self.layout.spec.lights, scene.light_cycle_scale)
        width = self.layout.routes.path.shape[1] + RECOVERY_ROOM
        # paths as complex numbers x + iy (the ``path`` property shows them as (n, width, 2))
        self.path_z = np.zeros((n, width), dtype=np.complex128)
        self.path_heading = np.zeros((n, width))
        self.path_clearance = np.zeros((n, width))  # m from each path point to the road's edge
        # single-precision complex copies (x + iy, unit tangent e^{iθ}) for the planner's large
        # pairwise arrays: they stay in cache, and centimetres need no more precision
        self.path_c64 = np.zeros((n, width), dtype=np.complex64)
        self.path_dir = np.zeros((n, width), dtype=np.complex64)
        self.path_len = np.zeros(n)
        self.state = np.zeros((n, 4))  # x, y, θ, v
        self.route = np.full(n, -1, dtype=np.int64)
        self.s = np.zeros(n)
        self.offset = np.zeros(n)  # route arc length minus path arc length (recovery paths)
        self.lateral_error = np.zeros(n)
        self.heading_error = np.zeros(n)
        self.active = np.zeros(n, dtype=bool)
        self.reached = np.zeros(n, dtype=bool)
        self.collided = np.zeros(n, dtype=bool)
        self.recovering = np.zeros(n, dtype=bool)  # following a planned path back to the route
        # the step at which each agent's front reached the start of its route's shared zone
        # (the junction for a car, the crosswalk for a walker); -1 while it has not. The
        # planner gives uncontrolled agents that entered first the right of way (velocity.py)
        self.entered = np.full(n, -1, dtype=np.int64)
        # m from each agent's centre to its front along its path (zone entry, stop lines)
        self.front = np.where(self.is_car, self.length / 2, self.width / 2)
        # the clock as 0-d arrays, read through ``time`` and ``steps``: a batch keeps
        # them as rows of its own arrays and advances every world's at once (sim/batch.py)
        self._clock = np.zeros(())
        self._step_count = np.zeros((), dtype=np.int64)
        self.log: list[Collision] = []
        self.light_state = self.lights.states(0.0)
        self.nearest = np.zeros(n, dtype=np.int64)  # path sample nearest each agent (progress)
        self._row_start = np.arange(n)[:, None] * width  # flat index of each agent's path start
        # the footprints' covering circles (as the collision check's), and the path sample
        # offset nearest each, for the quick on-road test
        circles = covering_circles(self.is_car, self.length, self.width)
        self._reach2, self._circle_offsets, self._circle_radius = circles
        self._offroad_candidates = np.zeros(n, dtype=bool)  # written by each step
        self._circle_samples = np.rint(self._circle_offsets / PATH_SPACING).astype(np.int64)

    # ----------------------------------------------------------------------------- placement
    def place(self, agent: int, route: int, s: float, speed: float = 0.0) -> None:
        """Put `agent` on `route` at arc length `s` (m), heading along it."""
        table = self.layout.routes
        if table.kind[route] != self.kind[agent]:
            raise ValueError(
                f"agent {agent} is a {'car' if self.is_car[agent] else 'pedestrian'}; "
                f"route '{table.names[route]}' is not"
            )
        self.follow_route(agent, route)
        k = int(round(s / PATH_SPACING))
        self.state[agent] = [*table.path[route, k], table.heading[route, k], speed]
        self.s[agent] = k * PATH_SPACING
        self.lateral_error[agent] = self.heading_error[agent] = 0.0
        self.offset[agent] = 0.0
        self.active[agent] = True
        self.reached[agent] = self.collided[agent] = self.recovering[agent] = False
        self.entered[agent] = -1
        self._update_entered()

    def follow_route(self, agent: int, route: int) -> None:
        """Make route `route`'s path the one `agent` follows (progress is kept): the rows
        `set_path` would write, copied from the layout's table of them."""
        rows = route_rows(self.layout, self.path_z.shape[1])
        self.route[agent] = route
        self.path_z[agent] = rows.z[route]
        self.path_heading[agent] = rows.heading[route]
        self.path_clearance[agent] = rows.clearance[route]
        self.path_dir[agent] = rows.direction[route]
        self.path_c64[agent] = rows.c64[route]
        self.path_len[agent] = rows.length[route]

    def set_path(
        self,
        agent: int,
        path: np.ndarray,
        heading: np.ndarray,
        length: float,
        clearance: np.ndarray | None = None,
    ) -> None:
        """Give `agent` a new path to follow (a recovery path; `follow_route` for a
        route's). `clearance` (m from each point to the road's edge) is computed when not
        given."""
        if clearance is None:
            clearance = self.layout.road_clearance(path)
        rows = _path_rows(path, heading, length, clearance, self.path_z.shape[1])
        self.path_z[agent], self.path_heading[agent], self.path_clearance[agent] = rows[:3]
        self.path_dir[agent], self.path_c64[agent], self.path_len[agent] = rows[3:]

    # ----------------------------------------------------------------------------- queries
    @property
    def path(self) -> np.ndarray:
        """Every agent's path as points (n, width, 2) (m); a view of `path_z`."""
        return self.path_z.view(np.float64).reshape(*self.path_z.shape, 2)

    @property
    def position(self) -> np.ndarray:
        """Positions as complex numbers x + iy (n,); a view of `state`."""
        return self.state.view(np.complex128)[:, 0]

    @property
    def route_s(self) -> np.ndarray:
        """Progress (m) in the coordinates of each agent's route (for stop lines and zones)."""
        return self.s + self.offset

    def corners(self, idx: np.ndarray | None = None) -> np.ndarray:
        """Footprint corners (len(idx), 4, 2) of the given agents (all by default)."""
        idx = np.arange(self.n) if idx is None else idx
        x, y, th, _ = self.state[idx].T
        return footprint_corners(x, y, th, self.length[idx], self.width[idx])

    def path_points(
        self, s: np.ndarray, agents: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Points and headings at arc lengths `s` (shape (n,) or (n, ...)) on each agent's path."""
        k = np.rint(s / PATH_SPACING).astype(np.int64)
        np.minimum(np.maximum(k, 0, out=k), self.path_z.shape[1] - 1, out=k)
        starts = self._row_start if agents is None else self._row_start[agents]
        k += starts.reshape((-1,) + (1,) * (k.ndim - 1))  # flat indices
        points = self.path_z.ravel().take(k)
        return points.view(np.float64).reshape(*k.shape, 2), self.path_heading.ravel().take(k)

    def path_samples(self, s: np.ndarray, agents: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points and unit tangents at arc lengths `s` (len(agents), ...), as complex64."""
        k = np.rint(s * (1.0 / PATH_SPACING)).astype(np.int64)
        np.minimum(np.maximum(k, 0, out=k), self.path_z.shape[1] - 1, out=k)
        k += self._row_start[agents].reshape((-1,) + (1,) * (k.ndim - 1))  # flat indices
        return self.path_c64.ravel().take(k), self.path_dir.ravel().take(k)

    def tracking_error(self) -> tuple[np.ndarray, np.ndarray]:
        """Lateral offset (m, left positive) and heading error (rad) of every agent from the
        nearest sample of its path, as of the last progress update."""
        return self.lateral_error, self.heading_error

    # ----------------------------------------------------------------------------- stepping
    def step(self, controls: np.ndarray) -> list[Collision]:
        """Advance every active agent by `dt` under `controls` (N, 2); returns new collisions.

        The per-agent arithmetic (dynamics, progress, zone entries, arrivals and the collision
        broad phase) is one compiled call (`kernels.advance_world`); Shapely runs only
        when that finds agents whose covering circles meet or a car not surely on the road.
        A `WorldBatch` runs the same three parts
        for many worlds, the compiled one for all at once."""
        self.begin_step()
        maybe_collided = kernels.advance_world(
            self.state, np.ascontiguousarray(controls, dtype=np.float64), self.is_car,
            self.params, self.dt, self.active, self.s, self.offset, self.path_z,
            self.path_heading, self.path_len, self.path_clearance, PATH_SPACING,
            *PROGRESS_WINDOW, self.nearest, self.lateral_error, self.heading_error, self.front,
            self.route, self.layout.routes.enter_s, self.entered, self.steps, self.length,
            GOAL_TOLERANCE, self.reached, self._circle_offsets, self._circle_samples,
            self._circle_radius, self._reach2, self._offroad_candidates,
        )  # fmt: skip
        return self.finish_step(maybe_collided)

    def __setstate__(self, state: dict) -> None:
        if "time" in state:  # pickled before the clock became 0-d arrays (stored states)
            state["_clock"] = np.array(float(state.pop("time")))
            state["_step_count"] = np.array(int(state.pop("steps")), dtype=np.int64)
            state["light_state"] = state["lights"].current
        self.__dict__.update(state)

    time = Entry("_clock", (), float)  # simulated seconds since the world was made (to the ns)
    steps = Entry("_step_count", (), int)  # steps taken since the world was made

    def begin_step(self) -> None:
        """The clock's part of `step`, before the agents move (`clock_ticks`)."""
        self._clock[()] = round(self.time + self.dt, 9)
        self._step_count[()] += 1

    def finish_step(self, maybe_collided: bool) -> list[Collision]:
        """The part of `step` after the agents moved: the lights at the new time and,
        when the broad phase found candidates, the exact collision check (a
        `WorldBatch` looks the lights up right after
        `begin_step` and calls `collide` only where needed)."""
        self.light_state = self.lights.states(self.time)
        return self.collide() if maybe_collided else []

    def collide(self) -> list[Collision]:
        """This step's exact collision check, once the broad phase found candidates."""
        events = self._collisions(self._offroad_candidates)
        self.log.extend(events)
        return events

    def _update_entered(self) -> None:
        """Mark the agents whose front has just reached the start of their shared zone."""
        kernels.mark_entered(
            self.s, self.offset, self.front, self.route, self.layout.routes.enter_s,
            self.active, self.entered, self.steps,
        )  # fmt: skip

    def _update_progress(self) -> None:
        """Project each agent onto its path near its previous progress (a local window: an
        agent moves at most a few samples per step); see `kernels.progress_into`."""
        kernels.progress_into(
            self.state, self.s, self.active, self.path_z, self.path_heading, self.path_len,
            PATH_SPACING, *PROGRESS_WINDOW, self.nearest, self.lateral_error, self.heading_error,
        )  # fmt: skip

    def surely_on_road(self) -> np.ndarray:
        """Cars whose footprint is certainly inside the (tolerant) drivable area: each of its
        three covering circles lies within the clearance of the path point nearest it. Cheap,
        and true for nearly every car following its path; the others get the exact test."""
        return kernels.surely_on_road(
            self.state,
            self.nearest,
            self._circle_offsets,
            self._circle_samples,
            self._circle_radius,
            self.path_z,
            self.path_clearance,
        )

    def _collisions(self, offroad_candidates: np.ndarray | None = None) -> list[Collision]:
        """This step's collisions; `offroad_candidates` (bool, N): the cars that get the exact
        off-road test (default: the active cars not `surely_on_road`)."""
        if offroad_candidates is None:
            offroad_candidates = self.is_car & self.active & ~self.surely_on_road()
        found = find_collisions(
            self.state,
            self.length,
            self.width,
            self.is_car,
            self.active,
            self.layout.drivable_tolerant,
            self.layout.tolerant_boundary_vertices,
            offroad_candidates=offroad_candidates,
        )
        out = []
        for a, b, kind in found:
            self.collided[a] = True
            if b >= 0:
                self.collided[b] = True
            out.append(Collision(self.steps, a, b, kind))
        return out
