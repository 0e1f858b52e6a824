"""Who was at fault in a collision: rules of the road applied to the world's recent history.

`FaultTracker` watches a world step by step (when each agent entered its shared zone, the
junction for a car and the crosswalk for a pedestrian, and the light it had then; the last few
seconds of states) and labels each collision. The rules, first match wins:

1. `offroad`: the car that left the road.
2. `red_light`: exactly one of the two entered its zone against a red light (a red traffic
   light, a "don't walk" crosswalk light): that one.
3. `rear_end`: two cars, one in the other's lane ahead of it (on its path, within 45° of
   the path's heading there; measured along the path, so curves count too): the follower.
   `cut_in` is True when the leader came in front of the follower less than
   `HISTORY` steps ago with a gap (bumper to bumper) shorter than the follower's stopping
   distance then (one planning period at its speed plus braking at
   `COMFORT_DECEL`): a follower that could not have stopped.
4. `moving_into_stationary`: exactly one of the two was moving (faster than
   `STATIONARY_SPEED`): the mover.
5. `car_yields_to_pedestrian`: a car and a pedestrian, both moving: the car.
6. `turn_yields`: two moving cars that came from opposite approaches (their routes' entry
   headings more than 135° apart), exactly one of them turning left (its route's heading turns
   left by more than 45°; right-hand traffic): the left-turner, which crosses the oncoming lane
   and must yield to the other going straight or turning right.
7. `entered_occupied`: two cars, both moving: the one that entered the junction later (a
   car not yet in the junction counts as entering now). Same step: both.
8. `shared`: otherwise both.

It also records, per car, whether it ever drove onto a crosswalk with a pedestrian on it that
it could have stopped for (`failed_to_yield`: its front reached a crosswalk on its route
while that crosswalk was occupied, and had been since a step at which the car was not yet
committed to it; see `fluids_bench.tasks.fluids.sim.crosswalks`).

When each agent entered its zone has one record, `World.entered` (the step, -1 while it has
not; the planner reads it too): the tracker reads it for rule 7 and judges the light of an
entry when the world marks it (its compiled record writes the same step into that array).
Re-placement (`World.place`, e.g. by `spawn` before a tracker is built) resets the agent's
entry: it enters again when its front reaches its route's zone (at once when placed inside it).
A tracker built on a world judges the light of every entry from then on; an agent already
inside its zone when the tracker is built has its light judged at the tracker's first record,
which also records that step as its entry. An agent re-placed after the tracker judged its
entry is judged again only when it was put on another route (the tracker recomputes its zone
thresholds when routes change); otherwise `ran_red` keeps its first verdict.
"""

from __future__ import annotations

import functools

import numpy as np

from fluids_bench.core.compiled import kernel
from fluids_bench.tasks.fluids.sim.crosswalks import crosswalks_of, record_yield_step
from fluids_bench.tasks.fluids.sim.kernels import record_fault_step
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.sim.lights import STOP

HISTORY = 40  # steps of states kept for the cut-in test (4 s at dt = 0.1)
STATIONARY_SPEED = 0.2  # m/s
COMFORT_DECEL = 5.0  # m/s², the supervisor's braking
REACTION = 0.5  # s, one planning period of the supervisor
SAME_HEADING = np.pi / 4
AHEAD = 30.0  # m of the follower's path searched for a leader


def _wrap(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


@functools.lru_cache(maxsize=32)
def route_turns(routes) -> tuple[np.ndarray, np.ndarray]:
    """Each route's entry heading (R,) and whether it turns (R,): its heading changes by more
    than 45° from start to end. Computed once per route table; callers only read them."""
    last = np.minimum(
        np.rint(routes.length / PATH_SPACING).astype(np.int64), routes.heading.shape[1] - 1
    )
    start = routes.heading[:, 0]
    end = routes.heading[np.arange(len(last)), last]
    return start, _wrap(end - start) > np.pi / 4  # a left turn (right-hand traffic)


def turns_across(start: np.ndarray, turning: np.ndarray, ra, rb):
    """Whether route `ra` turns left across route `rb` coming the other way (rule 6: the
    two entry headings more than 135° apart, `ra` turning left and `rb` going straight or
    turning right); elementwise."""
    opposite = np.abs(_wrap(start[ra] - start[rb])) > 3 * np.pi / 4
    return opposite & turning[ra] & ~turning[rb]


@kernel
def _record_step(
    s, offset, front, enter, light_of, prev_lights, lights, stop, entry_step, ran_red, step,
    state, ring, slot, yield_check, route, active, is_car, car_enter, prev_at, prev_occupied,
    warned, failed, width, centre, axis, half,
):  # fmt: skip  # pragma: no cover (compiled)
    """One step of `FaultTracker.update` in one compiled call: zone entries, red lights
    and history (`record_fault_step`), then, with `yield_check`, the crosswalks
    (`record_yield_step`), both at the agents' route arc lengths `s + offset`."""
    route_s = s + offset
    record_fault_step(
        route_s, front, enter, light_of, prev_lights, lights, stop, entry_step, ran_red, step,
        state, ring, slot,
    )  # fmt: skip
    if yield_check:
        record_yield_step(
            route_s, front, route, active, is_car, car_enter, prev_at, prev_occupied, warned,
            failed, state, width, centre, axis, half,
        )  # fmt: skip


@kernel
def record_steps(
    stepping, s, offset, front, enter, light_of, prev_lights, lights, stop, entry_step, ran_red,
    steps, state, ring, slots, yield_check, route, active, is_car, car_enter, prev_at,
    prev_occupied, warned, failed, width, centre, axis, half,
):  # fmt: skip  # pragma: no cover (compiled)
    """`_record_step` on row `b` of every per-world array where `stepping[b]` (at
    step `steps[b]`, into ring slot `slots[b]`)."""
    for b in range(len(stepping)):
        if stepping[b]:
            _record_step(
                s[b], offset[b], front, enter[b], light_of[b], prev_lights[b], lights[b], stop,
                entry_step[b], ran_red[b], steps[b], state[b], ring[b], slots[b], yield_check,
                route[b], active[b], is_car, car_enter, prev_at[b], prev_occupied[b], warned[b],
                failed[b], width, centre, axis, half,
            )  # fmt: skip


class FaultTracker:
    """Follows one world (call `update` after every `world.step`) and labels collisions."""

    def __init__(self, world) -> None:
        self.world = world
        n = world.n
        self.ran_red = np.zeros(n, dtype=bool)
        # a car that drove onto an occupied crosswalk it could have stopped for (crosswalks.py)
        self.failed_to_yield = np.zeros(n, dtype=bool)
        self._crosswalks = crosswalks_of(world.layout)
        self._yield_check = self._crosswalks.count > 0 and not world.is_car.all()
        self._prev_at = np.full(n, np.inf)  # route_s + front at the last step (inf: none yet)
        self._prev_occupied = np.zeros(self._crosswalks.count, dtype=bool)
        self._warned = np.zeros((n, self._crosswalks.count), dtype=bool)
        self._route_key = b""  # world.route's bytes when _enter was computed
        self._enter = np.full(n, np.inf)  # route_s + front at which each agent enters its zone
        self._light_of = np.full(n, -1, dtype=np.int64)  # the light at each agent's zone
        self._ring = np.empty((HISTORY, n, world.state.shape[1]))  # the last states, a ring
        # states recorded so far (the newest is in slot recorded - 1); a 0-d array, so that a
        # batch keeps it as an entry of its own (sim/batch.py)
        self._recorded = np.zeros((), dtype=np.int64)
        self._prev_lights = np.array(world.light_state)
        self._turns = route_turns(world.layout.routes)
        self._record()

    def update(self) -> None:
        """Record this step: new zone entries (with the light seen on the previous step) and
        the agents' states."""
        self._record()

    def _follow_routes(self) -> None:
        """Recompute the zone thresholds when routes were assigned or changed (in place: a
        `FaultBatch` holds these arrays as rows)."""
        w = self.world
        key = w.route.tobytes()
        if key != self._route_key:
            self._route_key = key
            r = np.maximum(w.route, 0)
            self._enter[:] = w.layout.routes.enter_s[r]
            # no zone, or an entry already judged (one the world recorded since this tracker's
            # first record; at that first one, an agent already inside is judged then)
            judged = w.entered >= 0 if int(self._recorded) else False
            self._enter[(w.route < 0) | judged] = np.inf
            self._light_of[:] = np.where(w.route >= 0, w.layout.routes.light[r], -1)
            self._prev_at[:] = np.inf  # a new route's arc lengths: no crossing this step

    def __setstate__(self, state: dict) -> None:
        if isinstance(state["_recorded"], int):  # pickled before the count was a 0-d array
            state["_recorded"] = np.array(state["_recorded"], dtype=np.int64)
        # pickled when the tracker kept its own copy of World.entered (the same steps)
        state.pop("entry_step", None)
        self.__dict__.update(state)

    def _record(self) -> None:
        w = self.world
        self._follow_routes()
        cw = self._crosswalks
        _record_step(
            w.s, w.offset, w.front, self._enter, self._light_of, self._prev_lights,
            w.light_state, STOP, w.entered, self.ran_red, w.steps, w.state, self._ring,
            int(self._recorded) % HISTORY, self._yield_check, w.route, w.active, w.is_car,
            cw.car_enter, self._prev_at, self._prev_occupied, self._warned,
            self.failed_to_yield, w.width, cw.centre, cw.axis, cw.half,
        )  # fmt: skip
        self._recorded[()] += 1

    def _history(self) -> list[np.ndarray]:
        """The kept states, oldest first (at most `HISTORY`)."""
        recorded = int(self._recorded)
        kept = min(recorded, HISTORY)
        return [self._ring[(recorded - kept + k) % HISTORY] for k in range(kept)]

    # ------------------------------------------------------------------ labels
    def label(self, a: int, b: int, kind: str) -> dict:
        """`{"at_fault": [agents], "rule": name, "cut_in": bool}` for collision (a, b, kind)."""
        w = self.world
        if b < 0 or kind == "offroad":
            return {"at_fault": [a], "rule": "offroad", "cut_in": False}
        if self.ran_red[a] != self.ran_red[b]:
            return {"at_fault": [a if self.ran_red[a] else b], "rule": "red_light", "cut_in": False}
        both_cars = bool(w.is_car[a] and w.is_car[b])
        if both_cars:
            follower = self._follower(a, b, w.state)
            if follower is not None:
                leader = b if follower == a else a
                return {
                    "at_fault": [follower],
                    "rule": "rear_end",
                    "cut_in": self._cut_in(follower, leader),
                }
        moving = w.state[[a, b], 3] > STATIONARY_SPEED
        if moving.sum() == 1:
            mover = a if moving[0] else b
            return {"at_fault": [mover], "rule": "moving_into_stationary", "cut_in": False}
        if not both_cars:
            car = a if w.is_car[a] else b
            return {"at_fault": [car], "rule": "car_yields_to_pedestrian", "cut_in": False}
        if moving.all():
            turner = self._turning_across(a, b)
            if turner is not None:
                return {"at_fault": [turner], "rule": "turn_yields", "cut_in": False}
            now = w.steps
            ea = w.entered[a] if w.entered[a] >= 0 else now
            eb = w.entered[b] if w.entered[b] >= 0 else now
            if ea != eb:
                return {
                    "at_fault": [a if ea > eb else b],
                    "rule": "entered_occupied",
                    "cut_in": False,
                }
        return {"at_fault": [a, b], "rule": "shared", "cut_in": False}

    def _turning_across(self, a: int, b: int) -> int | None:
        """Of two cars from opposite approaches, the one that turns (None unless exactly one)."""
        ra, rb = self.world.route[a], self.world.route[b]
        if ra < 0 or rb < 0:
            return None
        if turns_across(*self._turns, ra, rb):
            return a
        if turns_across(*self._turns, rb, ra):
            return b
        return None

    def _follower(self, a: int, b: int, state: np.ndarray) -> int | None:
        """The car behind when one of `a`, `b` is on the other's path ahead of it (see
        `_ahead_gap`), else None. Where each is on the other's path (side by side),
        the one whose centre is behind along their mean heading."""
        a_behind = self._ahead_gap(state, a, b) is not None
        b_behind = self._ahead_gap(state, b, a) is not None
        if a_behind != b_behind:
            return a if a_behind else b
        if not a_behind:
            return None
        d = complex(state[b, 0] - state[a, 0], state[b, 1] - state[a, 1])
        mean = state[a, 2] + 0.5 * _wrap(state[b, 2] - state[a, 2])
        return a if (d * np.exp(-1j * mean)).real > 0 else b

    def _cut_in(self, follower: int, leader: int) -> bool:
        """The leader came in front of the follower within the kept history, closer than the
        follower's stopping distance at that moment."""
        states = self._history()
        first = None
        for k in range(len(states) - 1, -1, -1):
            if self._ahead_gap(states[k], follower, leader) is None:
                break
            first = k
        if first is None or first == 0:
            return False  # in front for the whole history (or never seen so): no cut-in
        gap = self._ahead_gap(states[first], follower, leader)
        v = states[first][follower, 3]
        stop = v * REACTION + v * v / (2 * COMFORT_DECEL)
        return bool(gap < stop)

    def _ahead_gap(self, state: np.ndarray, follower: int, leader: int) -> float | None:
        """Bumper gap (m), measured along the follower's path, when `leader` is in the
        follower's lane ahead of it, else None. In the lane ahead: the leader's centre lies
        within `AHEAD` metres ahead along the follower's path, within half the two
        widths of it, heading within 45° of the path there. Measured along the path, not the
        follower's heading, so that it holds on curves (a roundabout's ring) too."""
        w = self.world
        path = w.path_z[follower, : int(w.path_len[follower] / PATH_SPACING) + 1]
        here = int(np.argmin(np.abs(path - complex(state[follower, 0], state[follower, 1]))))
        ahead = path[here : here + int(AHEAD / PATH_SPACING) + 1]
        d = np.abs(ahead - complex(state[leader, 0], state[leader, 1]))
        k = int(np.argmin(d))
        if k == 0 or d[k] > (w.width[follower] + w.width[leader]) / 2:
            return None
        if abs(_wrap(state[leader, 2] - w.path_heading[follower, here + k])) >= SAME_HEADING:
            return None
        return float(k * PATH_SPACING - (w.length[follower] + w.length[leader]) / 2)

    def annotate(self, events) -> list[dict]:
        """The collisions `events` as dicts with their fault labels."""
        return [{**e.as_dict(), **self.label(e.a, e.b, e.kind)} for e in events]
