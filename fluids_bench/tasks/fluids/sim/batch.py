"""B worlds of one scene stepped by one compiled call.

Each per-agent array that differs between the worlds is stored as one row of a (B, ...) array;
each world's attribute is a view of its row. :class:`World` only ever writes its arrays in
place, so the views stay bound while it steps; a world built afresh (a reset) or put back from
a snapshot is bound again with :meth:`WorldBatch.bind`, which copies its values into its rows.
The arrays every world of the scene shares (kinds, sizes, covering circles) are the first
world's. :meth:`WorldBatch.step` is :meth:`World.step` for every world whose mask is set, with
the per-agent arithmetic of all of them in one call (:func:`kernels.advance_worlds`, which runs
:func:`kernels.advance_world` on each row: the same arithmetic, so each world moves bit for bit
as alone).
"""

from __future__ import annotations

import numpy as np

from fluids_bench.tasks.fluids.sim import kernels
from fluids_bench.tasks.fluids.sim.fault import HISTORY, FaultTracker, record_steps
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.sim.lights import STOP
from fluids_bench.tasks.fluids.sim.world import (
    GOAL_TOLERANCE,
    PROGRESS_WINDOW,
    Collision,
    World,
)

# the World arrays that differ between worlds of one scene (written by steps, spawns, paths)
PER_WORLD = (
    "state", "params", "active", "s", "offset", "path_z", "path_heading", "path_len",
    "path_clearance", "path_c64", "path_dir", "collided", "nearest", "lateral_error",
    "heading_error", "route", "entered", "reached", "_offroad_candidates",
)  # fmt: skip
# the FaultTracker arrays (each world's own; written in place)
PER_TRACKER = (
    "entry_step", "ran_red", "failed_to_yield", "_prev_at", "_prev_occupied", "_warned",
    "_enter", "_light_of", "_ring", "_prev_lights",
)  # fmt: skip


class Rows:
    """Named arrays of B objects stored as rows of (B, ...) arrays: each object's attribute is
    a view of its row. The objects must write those arrays in place, never reassign them."""

    def __init__(self, objects: list, names: tuple[str, ...]) -> None:
        self.objects = list(objects)
        self.rows = {name: np.stack([getattr(o, name) for o in objects]) for name in names}
        for i, obj in enumerate(objects):
            self.bind(i, obj)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.rows[name]

    def bind(self, index: int, obj) -> None:
        """Make ``obj`` object ``index``: its values go into row ``index`` and its arrays
        become views of that row."""
        for name, rows in self.rows.items():
            rows[index] = getattr(obj, name)
            setattr(obj, name, rows[index])
        self.objects[index] = obj


class WorldBatch(Rows):
    """Row storage and the batched step of ``worlds`` (all of one scene, with one layout)."""

    def __init__(self, worlds: list[World]) -> None:
        super().__init__(worlds, PER_WORLD)
        first = worlds[0]
        self.controls = np.zeros((len(worlds), first.n, 2))
        self.steps = np.zeros(len(worlds), dtype=np.int64)  # each world's step count
        self.times = np.zeros(len(worlds))  # each world's clock after its last step (s)
        self._maybe = np.zeros(len(worlds), dtype=np.bool_)

    @property
    def worlds(self) -> list[World]:
        return self.objects

    def step(self, stepping: np.ndarray) -> list[list[Collision]]:
        """Advance the worlds where ``stepping`` (bool, (B,)) is set under their rows of
        :attr:`controls` (written by the caller), as :meth:`World.step` would; returns each
        world's new collisions (empty for the others)."""
        worlds, rows = self.worlds, self.rows
        index = stepping.nonzero()[0].tolist()
        for i in index:
            world = worlds[i]
            world.begin_step()
            self.steps[i], self.times[i] = world.steps, world.time
            # World.finish_step's lights, here: they depend on the clock alone
            world.light_state = world.lights.states(world.time)
        w = worlds[0]  # the arrays every world shares
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
        for i in (self._maybe & stepping).nonzero()[0].tolist():
            events[i] = worlds[i].collide()
        return events


class FaultBatch(Rows):
    """Row storage and the batched :meth:`FaultTracker.update` of the trackers of a
    :class:`WorldBatch`'s worlds."""

    def __init__(self, trackers: list[FaultTracker]) -> None:
        first = trackers[0]
        # the routes each tracker last followed here (FaultTracker._follow_routes recomputes
        # its zone thresholds only when they change); -2: bound since, not followed yet
        self._followed = np.full((len(trackers), len(first.world.route)), -2, dtype=np.int64)
        super().__init__(trackers, PER_TRACKER)
        # each world's light states, as recorded by the last update (its rows that stepped)
        self.lights = np.zeros((len(trackers), len(first.world.light_state)), dtype=np.int8)
        self._slots = np.zeros(len(trackers), dtype=np.int64)

    @property
    def trackers(self) -> list[FaultTracker]:
        return self.objects

    def bind(self, index: int, obj) -> None:
        super().bind(index, obj)
        self._followed[index] = -2

    def update(self, stepping: np.ndarray, worlds: WorldBatch) -> None:
        """:meth:`FaultTracker.update` of each tracker where ``stepping`` (its world stepped)."""
        trackers, lights, slots = self.objects, self.lights, self._slots
        # FaultTracker._follow_routes, called only where the routes changed since the last
        # call (elsewhere it would find its thresholds current)
        routes = worlds["route"]
        changed = stepping & (routes != self._followed).any(axis=1)
        for i in changed.nonzero()[0].tolist():
            trackers[i]._follow_routes()
        self._followed[changed] = routes[changed]
        for i in stepping.nonzero()[0].tolist():
            tracker = trackers[i]
            lights[i] = tracker.world.light_state
            slots[i] = tracker._recorded % HISTORY
            tracker._recorded += 1
        w, cw, rows = worlds.worlds[0], trackers[0]._crosswalks, worlds.rows
        record_steps(
            stepping, rows["s"], rows["offset"], w.front, self["_enter"], self["_light_of"],
            self["_prev_lights"], lights, STOP, self["entry_step"], self["ran_red"],
            worlds.steps, rows["state"], self["_ring"], slots, trackers[0]._yield_check,
            rows["route"], rows["active"], w.is_car, cw.car_enter, self["_prev_at"],
            self["_prev_occupied"], self["_warned"], self["failed_to_yield"], w.width,
            cw.centre, cw.axis, cw.half,
        )  # fmt: skip
