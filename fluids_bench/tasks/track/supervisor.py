"""The track's supervisor: a deterministic depth-`D` search through the car's model.

Every sequence of `D` steering actions in {-15°, 0, +15°}^D is scored by simulating the car
(without the crash reset) and the first action of the cheapest sequence is returned. The cost of
a sequence, per step `k` until the first exit from the road:

    (d_k / w)^2                         deviation from the centre line (d: distance, w: half-width)
    - progress_weight * min(a_k, v) / v progress along the track (a_k: arc gained by the step)

and, when step `k` leaves the road, `CRASH_COST * (D - k + 1)` and the sequence ends there
(a later exit costs less, so an unavoidable crash is put off). Capping the per-step progress at
the step length keeps a jump of the nearest centre-line point across an inner corner from
paying, and gives every partial sequence an exact lower bound on its cost.

The search is a depth-first branch and bound compiled with numba: a branch is cut when its
lower bound exceeds the best cost known. The previous plan's tail (plus one straight step)
seeds that bound when the car executed the plan's first action, so the usual case explores few
branches. Cutting only branches that cannot tie, and taking the first of equal costs in the
fixed enumeration order (straight, left, right at each depth), makes the result exactly the
exhaustive search's argmin whatever bound seeded it: the label is a pure function of the car's
pose and the track. A small cache keyed on the exact pose makes repeated labels free.

Depth is the quality knob (`depth=1` is myopic and crashes at sharp corners; the default
drives with few crashes).
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np
from numba import njit

from fluids_bench.tasks.track.sim import STEERING, Track, TrackConfig, project

CRASH_COST = 1000.0
DEFAULT_PROGRESS_WEIGHT = 1.0
CACHE_SIZE = 4096
ORDER = np.array([1, 0, 2], dtype=np.int64)  # straight first: ties go to driving straight
TURNS = np.array(STEERING, dtype=np.float64)
SLACK = 1e-9  # floating-point allowance of the lower bound


@njit(cache=True, nogil=True)
def _search(
    vertices, directions, lengths, starts, perimeter, half_width, speed,
    x0, y0, heading0, depth, progress_weight, turns, order, bound, plan,
):  # pragma: no cover (compiled)  # fmt: skip
    """Branch and bound over all steering sequences; fills `plan` with the best one (action
    indices) and returns its cost. `bound`: a cost known to be reachable (or +inf)."""
    n = depth + 1
    xs, ys, hs = np.empty(n), np.empty(n), np.empty(n)
    arcs, acc = np.empty(n), np.empty(n)
    choice = np.zeros(depth, np.int64)  # index into ``order`` at each depth
    current = np.empty(depth, np.int64)
    xs[0], ys[0], hs[0], acc[0] = x0, y0, heading0, 0.0
    arcs[0] = project(vertices, directions, lengths, starts, x0, y0)[1]
    best = np.inf
    limit = bound
    k = 0  # depth of the node being expanded
    while k >= 0:
        if choice[k] == 3:  # all children done: back up
            choice[k] = 0
            k -= 1
            if k >= 0:
                choice[k] += 1
            continue
        a = order[choice[k]]
        current[k] = a
        h = hs[k] + turns[a]
        x = xs[k] + speed * math.cos(h)
        y = ys[k] + speed * math.sin(h)
        d, arc, _ = project(vertices, directions, lengths, starts, x, y)
        if d > half_width:
            # a crash at step k + 1 ends the sequence; its continuations all cost the same,
            # so it stands for the first of them (straight onward)
            cost = acc[k] + CRASH_COST * (depth - k)
            if cost < best:
                best = cost
                limit = min(limit, best)
                for j in range(k + 1):
                    plan[j] = current[j]
                for j in range(k + 1, depth):
                    plan[j] = order[0]
            choice[k] += 1
            continue
        gain = (arc - arcs[k] + perimeter / 2.0) % perimeter - perimeter / 2.0
        step_cost = (d / half_width) ** 2 - progress_weight * min(gain, speed) / speed
        total = acc[k] + step_cost
        if k + 1 == depth:
            if total < best:
                best = total
                limit = min(limit, best)
                for j in range(depth):
                    plan[j] = current[j]
            choice[k] += 1
            continue
        # the remaining steps can at most each gain a full step of progress
        if total - progress_weight * (depth - k - 1) > limit + SLACK:
            choice[k] += 1
            continue
        xs[k + 1], ys[k + 1], hs[k + 1], arcs[k + 1], acc[k + 1] = x, y, h, arc, total
        k += 1
    return best


@njit(cache=True, nogil=True)
def _sequence_cost(
    vertices, directions, lengths, starts, perimeter, half_width, speed,
    x0, y0, heading0, progress_weight, turns, sequence,
):  # pragma: no cover (compiled)  # fmt: skip
    """The cost of one steering sequence, computed exactly as `_search` computes it."""
    depth = sequence.shape[0]
    x, y, h = x0, y0, heading0
    arc0 = project(vertices, directions, lengths, starts, x0, y0)[1]
    total = 0.0
    for k in range(depth):
        h = h + turns[sequence[k]]
        x = x + speed * math.cos(h)
        y = y + speed * math.sin(h)
        d, arc, _ = project(vertices, directions, lengths, starts, x, y)
        if d > half_width:
            return total + CRASH_COST * (depth - k)
        gain = (arc - arc0 + perimeter / 2.0) % perimeter - perimeter / 2.0
        total = total + ((d / half_width) ** 2 - progress_weight * min(gain, speed) / speed)
        arc0 = arc
    return total


class SearchSupervisor:
    """Labels for one track: `action(x, y, heading)` is the first step of the best plan."""

    def __init__(
        self,
        track: Track,
        config: TrackConfig,
        depth: int,
        progress_weight: float = DEFAULT_PROGRESS_WEIGHT,
    ) -> None:
        self.track = track
        self.config = config
        self.depth = depth
        self.progress_weight = float(progress_weight)
        self._cache: OrderedDict[tuple[float, float, float], np.ndarray] = OrderedDict()
        self._last: tuple[tuple[float, float, float], np.ndarray] | None = None
        self.searches = 0  # searches run (labels not served from the cache)

    def _geometry(self) -> tuple:
        t = self.track
        return (
            t.vertices, t.directions, t.lengths, t.starts, t.perimeter, t.half_width,
            self.config.speed,
        )  # fmt: skip

    def plan(self, x: float, y: float, heading: float, bound: float = math.inf) -> np.ndarray:
        """The best steering sequence (action indices) from this pose, searched afresh."""
        plan = np.zeros(self.depth, np.int64)
        _search(
            *self._geometry(), x, y, heading, self.depth, self.progress_weight, TURNS, ORDER,
            bound, plan,
        )  # fmt: skip
        return plan

    def sequence_cost(self, x: float, y: float, heading: float, sequence: np.ndarray) -> float:
        return _sequence_cost(
            *self._geometry(), x, y, heading, self.progress_weight, TURNS,
            np.asarray(sequence, dtype=np.int64),
        )  # fmt: skip

    def _tail_bound(self, key: tuple[float, float, float]) -> float:
        """The cost, from this pose, of the last plan's tail plus a straight step, if the car
        just executed that plan's first action without crashing; else +inf."""
        if self._last is None:
            return math.inf
        (px, py, ph), plan = self._last
        heading = ph + STEERING[plan[0]]
        x = px + self.config.speed * math.cos(heading)
        y = py + self.config.speed * math.sin(heading)
        if (x, y) != key[:2]:
            return math.inf
        tail = np.append(plan[1:], ORDER[0])
        return self.sequence_cost(*key, tail)

    def action(self, x: float, y: float, heading: float) -> int:
        """The supervisor's steering action index (0: -15°, 1: straight, 2: +15°)."""
        key = (x, y, heading)
        plan = self._cache.get(key)
        if plan is None:
            plan = self.plan(x, y, heading, self._tail_bound(key))
            self.searches += 1
            self._cache[key] = plan
            if len(self._cache) > CACHE_SIZE:
                self._cache.popitem(last=False)
        self._last = (key, plan)
        return int(plan[0])
