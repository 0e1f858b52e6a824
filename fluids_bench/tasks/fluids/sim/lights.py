"""Looping traffic and crosswalk lights, evaluated for all lights at once.

States are coded by what they ask of the agent they govern: ``GO`` (green / white),
``CAUTION`` (yellow) and ``STOP`` (red).
"""

from __future__ import annotations

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


class LightProgram:
    """The programs of a layout's lights as arrays: ``states(t)`` is one vectorised lookup."""

    def __init__(self, lights, scale: float = 1.0) -> None:
        """``scale`` multiplies every phase's duration and every offset (light timing)."""
        self.names = tuple(light.name for light in lights)
        self.kinds = tuple(light.kind for light in lights)
        width = max((len(light.phases) for light in lights), default=1)
        self.ends = np.full((len(lights), width), np.inf)  # cumulative end time of each phase
        self.codes = np.full((len(lights), width), STOP, dtype=np.int8)
        self.cycle = np.ones(len(lights))
        self.offset = np.zeros(len(lights))
        self._described: dict[bytes, dict[str, str]] = {}
        self._valid = (np.inf, -np.inf)  # time interval over which self._last holds
        self._last = np.zeros(0, dtype=np.int8)
        for i, light in enumerate(lights):
            durations = [d for _, d in light.phases]
            if scale != 1.0:
                durations = [d * scale for d in durations]
            self.ends[i, : len(durations)] = np.cumsum(durations)
            self.codes[i, : len(durations)] = [_CODE[s] for s, _ in light.phases]
            self.cycle[i] = sum(durations)
            self.offset[i] = light.offset if scale == 1.0 else light.offset * scale

    def __len__(self) -> int:
        return len(self.names)

    def states(self, t: float) -> np.ndarray:
        """State code of every light at time ``t`` (s). Read-only; lights change rarely, so the
        last answer is reused while ``t`` stays inside the interval it holds for."""
        if self._valid[0] <= t < self._valid[1]:
            return self._last
        if not len(self):
            return np.zeros(0, dtype=np.int8)
        phase_t = np.mod(t + self.offset, self.cycle)
        idx = (phase_t[:, None] >= self.ends).sum(axis=1)
        self._last = self.codes[np.arange(len(self)), idx]
        self._last.setflags(write=False)
        start = np.where(idx > 0, self.ends[np.arange(len(self)), np.maximum(idx - 1, 0)], 0.0)
        self._valid = (t - (phase_t - start).min(), t + self.time_to_change(t).min())
        return self._last

    def time_to_change(self, t: float) -> np.ndarray:
        """Seconds until each light next changes state."""
        phase_t = np.mod(t + self.offset, self.cycle)
        nxt = np.where(self.ends > phase_t[:, None], self.ends, np.inf).min(axis=1)
        return nxt - phase_t

    def describe(self, t: float) -> dict[str, str]:
        """``{light name: colour}`` at time ``t``."""
        return self.describe_states(self.states(t))

    def describe_states(self, states: np.ndarray) -> dict[str, str]:
        """``{light name: colour}`` for state codes ``states`` (cached: lights change rarely)."""
        key = states.tobytes()
        if key not in self._described:
            self._described[key] = {
                n: STATE_NAMES[(k, int(c))]
                for n, k, c in zip(self.names, self.kinds, states, strict=True)
            }
        return dict(self._described[key])
