"""The numpy quasi-LIDAR ray caster as it was before the compiled kernel (reference for tests).

``cast`` is ``QLidarSensor.cast`` of commit b78cce7 (with its ``_agent_buffer``, ``_hit_agents``
and ``_hit_edges``) turned into a plain function of the sensor's parameters and the world, with
the arithmetic unchanged; ``observe`` is the sensor's ``observe`` around it. The compiled
version (``fluids_bench.tasks.fluids.sim.sensors.kernels``) must give the same readings up to the
stated tolerance (``test_sensor_kernels.py``, ``tests/kernel_compare.py``).
"""

from __future__ import annotations

import math

import numpy as np

from fluids_bench.tasks.fluids.sim.layout.compiled import CAR
from fluids_bench.tasks.fluids.sim.sensors.qlidar import (
    CAR_HIT,
    EDGE_HIT,
    NOTHING,
    PEDESTRIAN_HIT,
    road_edges,
)


def _setup(layout, rays: int, max_range: float):
    """What the sensor laid out once in ``__init__``: _trig, _mid, _seg_reach, _segs."""
    offsets = 2 * math.pi * np.arange(rays) / rays
    c, s = np.cos(offsets), np.sin(offsets)
    trig = np.array([[[c, s], [-c, s]], [[-s, c], [s, c]]])
    ed = road_edges(layout)
    n = len(ed.a)
    segs = np.vstack(
        [
            ed.e[:, 1],
            -ed.e[:, 0],
            ed.a[:, 1],
            ed.a[:, 0],
            np.full(n, EDGE_HIT),
            ed.angle,
            np.full(n, -0.0),
            np.full(n, math.pi / 2),
            np.full(n, math.pi),
        ]
    )
    return trig, ed.mid.T.copy(), max_range + ed.half, segs


def _agent_buffer(world, max_range: float) -> np.ndarray:
    hl, hw = world.length / 2, world.width / 2
    n = len(hl)
    return np.column_stack(
        [
            np.zeros((n, 2)),
            np.where(world.kind == CAR, CAR_HIT, PEDESTRIAN_HIT),
            np.zeros((n, 2)),
            np.full(n, math.pi),
            np.full(n, 2 * math.pi),
            -hl,
            -hw,
            hl,
            hw,
            max_range + np.hypot(world.length, world.width) / 2,
        ]
    )


def cast(world, ego: int = 0, rays: int = 64, max_range: float = 30.0, layout=None) -> np.ndarray:
    """The noiseless reading (rays, 4) float64 of a ``QLidarSensor(layout or world.layout,
    rays, max_range)`` for agent ``ego`` of ``world``."""
    rays, max_range = int(rays), float(max_range)
    trig, mid, seg_reach, all_segs = _setup(
        world.layout if layout is None else layout, rays, max_range
    )
    state = world.state
    x, y, th, v = state[ego].tolist()
    d = math.cos(th) * trig[0] + math.sin(th) * trig[1]  # [[dx, dy], [−dx, dy]]
    buf = _agent_buffer(world, max_range)
    np.subtract(state[:, :2], state[ego, :2], out=buf[:, :2])
    buf[:, 3:5] = state[:, 2:]
    near = world.active & (np.hypot(buf[:, 0], buf[:, 1]) <= buf[:, 11])
    near[ego] = False
    agents = buf[near]
    segs = all_segs[:, np.hypot(mid[0] - x, mid[1] - y) <= seg_reach]
    with np.errstate(divide="ignore", invalid="ignore"):
        dist = np.concatenate(
            [
                np.full((1, rays), max_range),
                _hit_agents(d[0], agents),
                _hit_edges(x, y, d, segs),
            ]
        )
    j = dist.argmin(axis=0)
    attrs = np.concatenate([[(NOTHING, th, v, math.pi, 2 * math.pi)], agents[:, 2:7], segs[4:].T])[
        j
    ]
    out = np.empty((rays, 4))
    out[:, 0] = dist[j, np.arange(rays)]
    out[:, 1] = attrs[:, 0]
    a = out[:, 2]
    np.subtract(attrs[:, 1], th, out=a)
    a += attrs[:, 3]
    a %= attrs[:, 4]
    a -= attrs[:, 3]
    np.subtract(attrs[:, 2], v, out=out[:, 3])
    return out


def _hit_agents(d, agents) -> np.ndarray:
    n = len(agents)
    cs = np.empty((2, 2, n, 1))  # [[c, s], [−s, c]] of each agent's heading
    np.cos(agents[:, 3], out=cs[0, 0, :, 0])
    np.sin(agents[:, 3], out=cs[0, 1, :, 0])
    np.negative(cs[0, 1], out=cs[1, 0])
    cs[1, 1] = cs[0, 0]
    pp = cs[..., 0] * agents[:, :2].T
    slabs = agents[:, 7:11].T.reshape(2, 2, n) + (pp[:, 0] + pp[:, 1])
    uu = cs * d[:, None]
    u = uu[:, 0] + uu[:, 1]
    t = slabs[..., None] * (1.0 / u)
    lo, hi = np.minimum(t[0], t[1]), np.maximum(t[0], t[1])
    near, far = np.maximum(lo[0], lo[1]), np.minimum(hi[0], hi[1])
    near = np.maximum(near, 0.0)
    return np.where(near <= far, near, np.inf)


def _hit_edges(x, y, d, segs) -> np.ndarray:
    rows = segs[:4] + np.array([[-0.0], [-0.0], [-y], [-x]])  # [ey, −ex, wy, wx]
    ey, nex, wy, wx = rows
    pair = rows.reshape(2, 2, -1, 1) * d[:, :, None]
    cross = pair[:, 0] + pair[:, 1]
    t = (wx * ey + wy * nex)[:, None] / cross[0]
    u = cross[1] / cross[0]
    return np.where((np.minimum(t, u) >= 0) & (u <= 1), t, np.inf)


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def observe(
    world,
    rng: np.random.Generator,
    ego: int = 0,
    rays: int = 64,
    max_range: float = 30.0,
    noise_var: float = 0.0,
    dropout: float = 0.0,
    max_speed: float = 10.0,
) -> np.ndarray:
    """``QLidarSensor(world.layout, rays, max_range, noise_var, dropout, max_speed).observe``."""
    out = cast(world, ego, rays, max_range)
    noise_std, speed_bound = math.sqrt(noise_var), 2.0 * float(max_speed)
    if noise_std > 0:
        noise = rng.standard_normal((rays, 3)) * noise_std
        out[:, 0] = np.clip(out[:, 0] + noise[:, 0], 0.0, float(max_range))
        out[:, 2] = _wrap(out[:, 2] + noise[:, 1])
        out[:, 3] = np.clip(out[:, 3] + noise[:, 2], -speed_bound, speed_bound)
    if dropout > 0:
        out[rng.random(rays) < dropout] = np.array([float(max_range), NOTHING, 0.0, 0.0])
    return out.astype(np.float32)
