"""Looping traffic and crosswalk lights, evaluated for all lights at once.

States are coded by what they ask of the agent they govern: `GO` (green / white),
`CAUTION` (yellow) and `STOP` (red).
"""

from __future__ import annotations

import functools

import numpy as np

GO, CAUTION, STOP = 0, 1, 2
_CODE = {"green": GO, "white": GO, "yellow": CAUTION, "red": STOP}
STATE_NAMES = {
    ("traffic", GO): "green",
    ("traffic", CAUTION): "yellow",
    ("traffic", STOP): "red",
    ("crosswalk", GO): "white",
    ("crosswalk", STOP): "red",
}


@functools.lru_cache(maxsize=64)
def _tables(lights: tuple, scale: float) -> tuple[np.ndarray, ...]:
    """The programs of `lights` as arrays (read-only): each phase's cumulative end time,
    each phase's state code, each light's cycle length and offset (s)."""
    width = max((len(light.phases) for light in lights), default=1)
    ends = np.full((len(lights), width), np.inf)
    codes = np.full((len(lights), width), STOP, dtype=np.int8)
    cycle, offset = np.ones(len(lights)), np.zeros(len(lights))
    for i, light in enumerate(lights):
        durations = [d for _, d in light.phases]
        if scale != 1.0:
            durations = [d * scale for d in durations]
        ends[i, : len(durations)] = np.cumsum(durations)
        codes[i, : len(durations)] = [_CODE[s] for s, _ in light.phases]
        cycle[i] = sum(durations)
        offset[i] = light.offset if scale == 1.0 else light.offset * scale
    for table in (ends, codes, cycle, offset):
        table.setflags(write=False)
    return ends, codes, cycle, offset


def look_up(ends, codes, cycle, offset, times, current, valid) -> None:
    """The state code of every light at each of `times` (s, (E,)) into `current` (E, L), and
    the interval `[lo, hi)` of times over which those codes hold into `valid` (E, 2):
    `LightProgram.states` for E clocks at once (a batch of worlds whose lights changed), with
    the same elementwise operations, so each row has the bits of a lookup alone. `ends`,
    `codes`, `cycle`, `offset`: a program's tables (`LightProgram`'s)."""
    lights = np.arange(len(cycle))
    phase_t = np.mod(times[:, None] + offset, cycle)  # (E, L)
    idx = (phase_t[..., None] >= ends).sum(axis=-1)
    current[...] = codes[lights, idx]
    start = np.where(idx > 0, ends[lights, np.maximum(idx - 1, 0)], 0.0)
    to_change = np.where(ends > phase_t[..., None], ends, np.inf).min(axis=-1) - phase_t
    valid[:, 0] = times - (phase_t - start).min(axis=-1)
    valid[:, 1] = times + to_change.min(axis=-1)


class LightProgram:
    """The programs of a layout's lights as arrays: `states(t)` is one vectorised lookup."""

    def __init__(self, lights, scale: float = 1.0) -> None:
        """`scale` multiplies every phase's duration and every offset (light timing)."""
        self.names = tuple(light.name for light in lights)
        self.kinds = tuple(light.kind for light in lights)
        # the tables are read-only and shared by every program of the same lights and scale
        self.ends, self.codes, self.cycle, self.offset = _tables(tuple(lights), scale)
        self._described: dict[bytes, dict[str, str]] = {}
        # the codes of the last lookup (written in place, so that a batch of worlds can keep
        # them as rows of its own arrays), and the time interval [lo, hi) over which they hold
        self.current = np.zeros(len(self.names), dtype=np.int8)
        self._valid = np.array([np.inf, -np.inf])

    def __setstate__(self, state: dict) -> None:
        if "_last" in state:  # pickled before the last lookup was kept in place
            state["current"] = np.array(state.pop("_last"), dtype=np.int8)
            state["_valid"] = np.array(state["_valid"], dtype=np.float64)
        self.__dict__.update(state)

    def __len__(self) -> int:
        return len(self.names)

    def states(self, t: float) -> np.ndarray:
        """State code of every light at time `t` (s): `current`, updated in place
        (read it, never write it). Lights change rarely, so the last answer is kept while `t`
        stays inside the interval it holds for."""
        valid = self._valid
        if valid[0] <= t < valid[1] or not len(self):
            return self.current
        times = np.array([t], dtype=np.float64)
        look_up(
            self.ends, self.codes, self.cycle, self.offset, times, self.current[None], valid[None]
        )
        return self.current

    def time_to_change(self, t: float) -> np.ndarray:
        """Seconds until each light next changes state."""
        phase_t = np.mod(t + self.offset, self.cycle)
        nxt = np.where(self.ends > phase_t[:, None], self.ends, np.inf).min(axis=1)
        return nxt - phase_t

    def describe(self, t: float) -> dict[str, str]:
        """`{light name: colour}` at time `t`."""
        return self.describe_states(self.states(t))

    def describe_states(self, states: np.ndarray) -> dict[str, str]:
        """`{light name: colour}` for state codes `states` (cached: lights change rarely)."""
        key = states.tobytes()
        if key not in self._described:
            self._described[key] = {
                n: STATE_NAMES[(k, int(c))]
                for n, k, c in zip(self.names, self.kinds, states, strict=True)
            }
        return dict(self._described[key])
