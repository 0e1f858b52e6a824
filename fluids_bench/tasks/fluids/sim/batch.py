"""B worlds of one scene stepped by one compiled call.

Each per-agent array that differs between the worlds is stored as one row of a (B, ...) array;
each world's attribute is a view of its row. `World` only ever writes its arrays in
place, so the views stay bound while it steps; a world built afresh (a reset) or put back from
a snapshot is bound again with `WorldBatch.bind`, which copies its values into its rows.
The arrays every world of the scene shares (kinds, sizes, covering circles) are the first
world's. `WorldBatch.step` is `World.step` for every world whose mask is set, with
the per-agent arithmetic of all of them in one call (`kernels.advance_worlds`, which runs
`kernels.advance_world` on each row: the same arithmetic, so each world moves bit for bit
as alone).
"""

from __future__ import annotations

import numpy as np

from fluids_bench.tasks.fluids.sim import kernels
from fluids_bench.tasks.fluids.sim.fault import HISTORY, FaultTracker, record_steps
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.sim.lights import STOP, look_up
from fluids_bench.tasks.fluids.sim.world import (
    GOAL_TOLERANCE,
    PROGRESS_WINDOW,
    Collision,
    World,
    clock_ticks,
)

# the World arrays that differ between worlds of one scene (written by steps, spawns, paths)
PER_WORLD = (
    "state", "params", "active", "s", "offset", "path_z", "path_heading", "path_len",
    "path_clearance", "path_c64", "path_dir", "collided", "nearest", "lateral_error",
    "heading_error", "route", "entered", "reached", "_offroad_candidates",
)  # fmt: skip
# the FaultTracker arrays (each world's own; written in place)
PER_TRACKER = (
    "ran_red", "failed_to_yield", "_prev_at", "_prev_occupied", "_warned", "_enter",
    "_light_of", "_ring", "_prev_lights", "_recorded",
)  # fmt: skip
# the World's clock (0-d arrays) and its light program's last lookup
CLOCK = ("_clock", "_step_count")
LIGHT_LOOKUP = ("current", "_valid")


class Rows:
    """Named arrays of B objects stored as rows of (B, ...) arrays: each object's attribute is
    a view of its row (a 0-d array's, of one entry). The objects must write those arrays in
    place, never reassign them."""

    def __init__(self, objects: list, names: tuple[str, ...]) -> None:
        self.objects = list(objects)
        self.rows = {name: np.stack([getattr(o, name) for o in objects]) for name in names}
        for i, obj in enumerate(objects):
            self.bind(i, obj)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.rows[name]

    def bind(self, index: int, obj) -> None:
        """Make `obj` object `index`: its values go into row `index` and its arrays
        become views of that row."""
        for name, rows in self.rows.items():
            rows[index] = getattr(obj, name)
            setattr(obj, name, rows[index, ...])
        self.objects[index] = obj


class WorldBatch(Rows):
    """Row storage and the batched step of `worlds` (all of one scene, with one layout)."""

    def __init__(self, worlds: list[World]) -> None:
        self.clocks = Rows(worlds, CLOCK)
        self.lookups = Rows([w.lights for w in worlds], LIGHT_LOOKUP)
        super().__init__(worlds, PER_WORLD)
        first = worlds[0]
        self.controls = np.zeros((len(worlds), first.n, 2))
        self.steps = self.clocks["_step_count"]  # each world's step count (B,)
        self.times = self.clocks["_clock"]  # each world's clock (s)
        self.lights = self.lookups["current"]  # each world's light states (B, L)
        self._maybe = np.zeros(len(worlds), dtype=np.bool_)
        self.hit = np.zeros(len(worlds), dtype=np.bool_)  # worlds with new collisions

    @property
    def worlds(self) -> list[World]:
        return self.objects

    def bind(self, index: int, world: World) -> None:
        super().bind(index, world)
        self.clocks.bind(index, world)
        self.lookups.bind(index, world.lights)
        world.light_state = world.lights.current

    def step(self, stepping: np.ndarray) -> list[list[Collision]]:
        """Advance the worlds where `stepping` (bool, (B,)) is set under their rows of
        `controls` (written by the caller), as `World.step` would; returns each
        world's new collisions (empty for the others; `hit` marks the worlds with
        some)."""
        worlds, rows = self.worlds, self.rows
        w = worlds[0]  # the arrays every world shares
        self._advance_clocks(stepping, w.dt)
        # World.finish_step's lights, here (they depend on the clock alone): looked up again
        # only in the worlds whose time left the interval their last lookup holds for
        if self.lights.shape[1]:
            lo, hi = self.lookups["_valid"][:, 0], self.lookups["_valid"][:, 1]
            expired = stepping & ~((lo <= self.times) & (self.times < hi))
            if expired.any():
                self._look_up_lights(expired.nonzero()[0])
        kernels.advance_worlds(
            stepping, rows["state"], self.controls, w.is_car, rows["params"], w.dt,
            rows["active"], rows["s"], rows["offset"], rows["path_z"], rows["path_heading"],
            rows["path_len"], rows["path_clearance"], PATH_SPACING, *PROGRESS_WINDOW,
            rows["nearest"], rows["lateral_error"], rows["heading_error"], w.front,
            rows["route"], w.layout.routes.enter_s, rows["entered"], self.steps, w.length,
            GOAL_TOLERANCE, rows["reached"], w._circle_offsets, w._circle_samples,
            w._circle_radius, w._reach2, rows["_offroad_candidates"], self._maybe,
        )  # fmt: skip
        # the rest of World.finish_step: the exact check where the broad phase found candidates
        events: list[list[Collision]] = [[] for _ in worlds]
        self.hit[:] = False
        for i in (self._maybe & stepping).nonzero()[0].tolist():
            events[i] = worlds[i].collide()
            self.hit[i] = bool(events[i])
        return events

    def _look_up_lights(self, index: np.ndarray) -> None:
        """`LightProgram.states` of the worlds `index` at their times: one `look_up` for all
        whose programs share the first one's tables (the worlds of one scene and light
        timing), the others world by world."""
        worlds, program = self.worlds, self.worlds[0].lights
        shared = np.array([worlds[i].lights.ends is program.ends for i in index.tolist()])
        for i in index[~shared].tolist():
            worlds[i].lights.states(worlds[i].time)
        index = index[shared]
        if len(index):
            current = np.empty((len(index), self.lights.shape[1]), self.lights.dtype)
            valid = np.empty((len(index), 2))
            look_up(
                program.ends, program.codes, program.cycle, program.offset, self.times[index],
                current, valid,
            )  # fmt: skip
            self.lights[index], self.lookups["_valid"][index] = current, valid

    def _advance_clocks(self, stepping: np.ndarray, dt: float) -> None:
        """`World.begin_step` of every stepping world: its new time read from
        `clock_ticks` (a clock set by hand off the ticks advances alone)."""
        steps, times = self.steps, self.times
        ticks = clock_ticks(dt, int(steps.max()) + 1)
        on_tick = ticks[steps] == times
        ticking = stepping & on_tick
        steps[ticking] += 1
        times[ticking] = ticks[steps[ticking]]
        for i in (stepping & ~on_tick).nonzero()[0].tolist():
            self.worlds[i].begin_step()


class FaultBatch(Rows):
    """Row storage and the batched `FaultTracker.update` of the trackers of a
    `WorldBatch`'s worlds."""

    def __init__(self, trackers: list[FaultTracker]) -> None:
        first = trackers[0]
        # the routes each tracker last followed here (FaultTracker._follow_routes recomputes
        # its zone thresholds only when they change); -2: bound since, not followed yet
        self._followed = np.full((len(trackers), len(first.world.route)), -2, dtype=np.int64)
        super().__init__(trackers, PER_TRACKER)

    @property
    def trackers(self) -> list[FaultTracker]:
        return self.objects

    def bind(self, index: int, obj) -> None:
        super().bind(index, obj)
        self._followed[index] = -2

    def update(self, stepping: np.ndarray, worlds: WorldBatch) -> None:
        """`FaultTracker.update` of each tracker where `stepping` (its world stepped)."""
        trackers = self.objects
        # FaultTracker._follow_routes, called only where the routes changed since the last
        # call (elsewhere it would find its thresholds current)
        routes = worlds["route"]
        changed = stepping & (routes != self._followed).any(axis=1)
        for i in changed.nonzero()[0].tolist():
            trackers[i]._follow_routes()
        self._followed[changed] = routes[changed]
        recorded = self["_recorded"]
        slots = recorded % HISTORY
        recorded += stepping
        w, cw, rows, lights = worlds.worlds[0], trackers[0]._crosswalks, worlds.rows, worlds.lights
        record_steps(
            stepping, rows["s"], rows["offset"], w.front, self["_enter"], self["_light_of"],
            self["_prev_lights"], lights, STOP, rows["entered"], self["ran_red"],
            worlds.steps, rows["state"], self["_ring"], slots, trackers[0]._yield_check,
            rows["route"], rows["active"], w.is_car, cw.car_enter, self["_prev_at"],
            self["_prev_occupied"], self["_warned"], self["failed_to_yield"], w.width,
            cw.centre, cw.axis, cw.half,
        )  # fmt: skip
