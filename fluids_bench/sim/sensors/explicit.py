"""The explicit ("global oracle") observation of ch. 7, as one flat float32 vector.

Layout, all in SI units, positions and headings of others in the ego's frame (x forward, y left):

* ego (5): x, y (m, world frame), cos θ, sin θ, v (m/s)
* goal (3): goal position in the ego frame (m), path length left to it (m)
* k nearest other agents (7 each): dx, dy, cos Δθ, sin Δθ, v, is_pedestrian, present
  (absent slots are all zero; ``present`` is the mask)
* light (5): one-hot of go / caution / stop / none for the ego's own signal, and the distance
  from the ego's front to its stop line (m, 0 once past it or without a light)

Optional zero-mean Gaussian noise with variance ``noise_var`` is added to every continuous entry
(not to masks or one-hots), drawn from the generator passed in.
"""

from __future__ import annotations

import numpy as np

from fluids_bench.sim.layout.compiled import PEDESTRIAN
from fluids_bench.sim.world import World

EGO, GOAL, PER_AGENT, LIGHT = 5, 3, 7, 5


def explicit_size(k_nearest: int) -> int:
    return EGO + GOAL + PER_AGENT * k_nearest + LIGHT


def _noise_mask(k_nearest: int) -> np.ndarray:
    mask = np.ones(explicit_size(k_nearest), dtype=bool)
    base = EGO + GOAL
    for k in range(k_nearest):
        mask[base + PER_AGENT * k + 5 : base + PER_AGENT * (k + 1)] = False  # is_ped, present
    mask[base + PER_AGENT * k_nearest : base + PER_AGENT * k_nearest + 4] = False  # one-hot
    return mask


class ExplicitSensor:
    def __init__(self, k_nearest: int = 8, noise_var: float = 0.0) -> None:
        self.k = k_nearest
        self.noise_std = float(np.sqrt(noise_var))
        self.noise_mask = _noise_mask(k_nearest)
        self.size = explicit_size(k_nearest)

    def observe(self, world: World, rng: np.random.Generator, ego: int = 0) -> np.ndarray:
        out = np.zeros(self.size, dtype=np.float64)
        state = world.state
        # scalars as Python floats: the same IEEE arithmetic, without numpy's per-call cost
        x, y, th, v = state[ego].tolist()
        c, s = float(np.cos(th)), float(np.sin(th))
        goal = world.path_z[ego, int(round(world.path_len[ego] / 0.5))]
        dx, dy = goal.real - x, goal.imag - y
        out[: EGO + GOAL] = (x, y, c, s, v, c * dx + s * dy, -s * dx + c * dy,
                             float(world.path_len[ego] - world.s[ego]))
        seen = world.active.copy()
        seen[ego] = False
        others = seen.nonzero()[0]
        if len(others):
            rel = state[others, :2] - (x, y)
            order = np.argsort(np.hypot(rel[:, 0], rel[:, 1]), kind="stable")[: self.k]
            idx, rel = others[order], rel[order]
            dth = state[idx, 2] - th
            rows = out[EGO + GOAL : EGO + GOAL + PER_AGENT * len(idx)].reshape(-1, PER_AGENT)
            rows[:, 0] = c * rel[:, 0] + s * rel[:, 1]
            rows[:, 1] = -s * rel[:, 0] + c * rel[:, 1]
            rows[:, 2] = np.cos(dth)
            rows[:, 3] = np.sin(dth)
            rows[:, 4] = state[idx, 3]
            rows[:, 5] = world.kind[idx] == PEDESTRIAN
            rows[:, 6] = 1.0
        base = EGO + GOAL + PER_AGENT * self.k
        routes = world.layout.routes
        r = world.route[ego]
        light = routes.light[r]
        gap = float(routes.stop_s[r] - (world.s[ego] + world.offset[ego] + world.length[ego] / 2))
        if light >= 0 and gap > -0.5:
            out[base + int(world.light_state[light])] = 1.0
            out[base + 4] = max(gap, 0.0)
        else:
            out[base + 3] = 1.0
        if self.noise_std > 0:
            out[self.noise_mask] += rng.normal(0.0, self.noise_std, int(self.noise_mask.sum()))
        return out.astype(np.float32)
