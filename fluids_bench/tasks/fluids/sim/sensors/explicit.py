"""The explicit ("global oracle") observation of ch. 7, as one flat float32 vector.

Layout, all in SI units, positions and headings of others in the ego's frame (x forward, y left):

* ego (5): x, y (m, world frame), cos θ, sin θ, v (m/s)
* goal (3): goal position in the ego frame (m), path length left to it (m)
* k nearest other agents (7 each): dx, dy, cos Δθ, sin Δθ, v, is_pedestrian, present
  (absent slots are all zero; `present` is the mask)
* light (5): one-hot of go / caution / stop / none for the ego's own signal, and the distance
  from the ego's front to its stop line (m, 0 once past it or without a light)

The noiseless vector is filled in one compiled pass (`kernels.fill_explicit`). Optional
zero-mean Gaussian noise with variance `noise_var` is added to every continuous entry
(not to masks or one-hots), drawn from the generator passed in.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING
from fluids_bench.tasks.fluids.sim.sensors.kernels import EGO, GOAL, LIGHT, PER_AGENT, fill_explicit
from fluids_bench.tasks.fluids.sim.world import World


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
        routes = world.layout.routes
        fill_explicit(
            out,
            world.state,
            world.active,
            world.kind,
            world.path_z,
            world.path_len,
            world.s,
            world.offset,
            world.length,
            world.route,
            routes.light,
            routes.stop_s,
            world.light_state,
            ego,
            self.k,
            PATH_SPACING,
        )
        if self.noise_std > 0:
            out[self.noise_mask] += rng.normal(0.0, self.noise_std, int(self.noise_mask.sum()))
        return out.astype(np.float32)


@njit(cache=True, nogil=True)
def fill_explicit_worlds(
    out, stepping, state, active, kind, path_z, path_len, s, offset, length, route,
    route_light, stop_s, light_state, k, spacing,
):  # fmt: skip  # pragma: no cover (compiled)
    """`fill_explicit` of agent 0 on row `b` of every per-world array, into the zeroed
    row `out[b]`, where `stepping[b]`."""
    for b in range(len(stepping)):
        if stepping[b]:
            out[b] = 0.0
            fill_explicit(
                out[b], state[b], active[b], kind, path_z[b], path_len[b], s[b], offset[b],
                length, route[b], route_light, stop_s, light_state[b], 0, k, spacing,
            )  # fmt: skip
