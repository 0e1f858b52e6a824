"""The FLUIDS world: struct-of-arrays state of every agent, one vectorised ``step``.

Agent 0 is always the ego car; cars come first, pedestrians after. Each agent follows its own
copy of a path (its route's, or a recovery path planned back to it), stored resampled every
``PATH_SPACING`` metres so that progress ``s`` (m along the path) indexes it directly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fluids_bench.sim.collision import find_collisions, footprint_corners
from fluids_bench.sim.config import SceneConfig
from fluids_bench.sim.dynamics import integrate
from fluids_bench.sim.layout.compiled import CAR, PEDESTRIAN, Layout, compile_layout
from fluids_bench.sim.layout.geometry import PATH_SPACING
from fluids_bench.sim.lights import LightProgram

GOAL_TOLERANCE = 0.5  # m between an arriving agent's front and the end of its path
RECOVERY_ROOM = 160  # extra path samples per agent, for recovery paths longer than the route


@dataclass(frozen=True)
class Collision:
    step: int
    a: int
    b: int  # -1 for offroad
    kind: str

    def as_dict(self) -> dict:
        return {"step": self.step, "a": self.a, "b": self.b, "kind": self.kind}


class World:
    """All agents of one scene on one compiled layout. Mutated only by :meth:`step` and the
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
        self.params = np.column_stack([np.where(self.is_car, car.mass, 1.0), np.full(n, car.lf),
                                       np.full(n, car.lr), self.max_speed])
        self.lights = LightProgram(self.layout.spec.lights)
        width = self.layout.routes.path.shape[1] + RECOVERY_ROOM
        self.path = np.zeros((n, width, 2))
        self.path_heading = np.zeros((n, width))
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
        self.time = 0.0
        self.steps = 0
        self.log: list[Collision] = []
        self.light_state = self.lights.states(0.0)
        self._window = np.arange(-3, 9)  # path samples searched around the last progress
        self._rows = np.arange(n)[:, None]

    # ----------------------------------------------------------------------------- placement
    def place(self, agent: int, route: int, s: float, speed: float = 0.0) -> None:
        """Put ``agent`` on ``route`` at arc length ``s`` (m), heading along it."""
        table = self.layout.routes
        if table.kind[route] != self.kind[agent]:
            raise ValueError(f"agent {agent} is a {'car' if self.is_car[agent] else 'pedestrian'}; "
                             f"route '{table.names[route]}' is not")
        self.route[agent] = route
        self.set_path(agent, table.path[route], table.heading[route], float(table.length[route]))
        k = int(round(s / PATH_SPACING))
        self.state[agent] = [*table.path[route, k], table.heading[route, k], speed]
        self.s[agent] = k * PATH_SPACING
        self.lateral_error[agent] = self.heading_error[agent] = 0.0
        self.offset[agent] = 0.0
        self.active[agent] = True
        self.reached[agent] = self.collided[agent] = self.recovering[agent] = False

    def set_path(self, agent: int, path: np.ndarray, heading: np.ndarray, length: float) -> None:
        """Give ``agent`` a new path to follow (its route's, or a recovery path)."""
        m = min(len(path), self.path.shape[1])
        self.path[agent, :m] = path[:m]
        self.path[agent, m:] = path[m - 1]
        self.path_heading[agent, :m] = heading[:m]
        self.path_heading[agent, m:] = heading[m - 1]
        self.path_dir[agent] = np.exp(1j * self.path_heading[agent])
        self.path_c64[agent] = self.path[agent, :, 0] + 1j * self.path[agent, :, 1]
        self.path_len[agent] = min(length, (m - 1) * PATH_SPACING)

    # ----------------------------------------------------------------------------- queries
    @property
    def route_s(self) -> np.ndarray:
        """Progress (m) in the coordinates of each agent's route (for stop lines and zones)."""
        return self.s + self.offset

    def corners(self, idx: np.ndarray | None = None) -> np.ndarray:
        """Footprint corners (len(idx), 4, 2) of the given agents (all by default)."""
        idx = np.arange(self.n) if idx is None else idx
        x, y, th, _ = self.state[idx].T
        return footprint_corners(x, y, th, self.length[idx], self.width[idx])

    def path_points(self, s: np.ndarray, agents: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Points and headings at arc lengths ``s`` (shape (n,) or (n, ...)) on each agent's path."""
        agents = np.arange(self.n) if agents is None else agents
        k = np.minimum(np.maximum(np.rint(s / PATH_SPACING).astype(np.int64), 0), self.path.shape[1] - 1)
        rows = agents.reshape((-1,) + (1,) * (k.ndim - 1))
        return self.path[rows, k], self.path_heading[rows, k]

    def path_samples(self, s: np.ndarray, agents: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points and unit tangents at arc lengths ``s`` (len(agents), ...), as complex64."""
        k = np.rint(s * (1.0 / PATH_SPACING)).astype(np.int64)
        np.minimum(np.maximum(k, 0, out=k), self.path.shape[1] - 1, out=k)
        rows = agents.reshape((-1,) + (1,) * (k.ndim - 1))
        return self.path_c64[rows, k], self.path_dir[rows, k]

    def tracking_error(self) -> tuple[np.ndarray, np.ndarray]:
        """Lateral offset (m, left positive) and heading error (rad) of every agent from the
        nearest sample of its path, as of the last progress update."""
        return self.lateral_error, self.heading_error

    # ----------------------------------------------------------------------------- stepping
    def step(self, controls: np.ndarray) -> list[Collision]:
        """Advance every active agent by ``dt`` under ``controls`` (N, 2); returns new collisions."""
        act = self.active
        new = integrate(self.state, controls, self.is_car, self.params, self.dt)
        self.state[act] = new[act]
        self.time = round(self.time + self.dt, 9)
        self.steps += 1
        self.light_state = self.lights.states(self.time)
        self._update_progress()
        arrived = act & (self.s >= self.path_len - self.length / 2 - GOAL_TOLERANCE)
        self.reached |= arrived
        self.active &= ~arrived
        events = self._collisions()
        self.log.extend(events)
        return events

    def _update_progress(self) -> None:
        """Project each agent onto its path near its previous progress (a local window: an
        agent moves at most a few samples per step)."""
        k = np.rint(self.s / PATH_SPACING).astype(np.int64)[:, None] + self._window
        np.minimum(np.maximum(k, 0, out=k), self.path.shape[1] - 1, out=k)
        rows = self._rows
        d = self.path[rows, k] - self.state[:, None, :2]
        best = k[rows[:, 0], np.einsum("nkd,nkd->nk", d, d).argmin(axis=1)]
        h = self.path_heading[rows[:, 0], best]
        off = self.state[:, :2] - self.path[rows[:, 0], best]
        ch, sh = np.cos(h), np.sin(h)
        along = np.minimum(np.maximum(off[:, 0] * ch + off[:, 1] * sh, -PATH_SPACING / 2), PATH_SPACING / 2)
        s = np.minimum(best * PATH_SPACING + along, self.path_len)
        self.s = np.where(self.active, s, self.s)
        # by-products for the supervisor: signed lateral offset and heading error from the path
        self.lateral_error = off[:, 1] * ch - off[:, 0] * sh
        self.heading_error = (self.state[:, 2] - h + np.pi) % (2 * np.pi) - np.pi

    def _collisions(self) -> list[Collision]:
        found = find_collisions(self.state, self.length, self.width, self.is_car, self.active,
                                self.layout.drivable_tolerant, self.layout.tolerant_boundary_vertices)
        out = []
        for a, b, kind in found:
            self.collided[a] = True
            if b >= 0:
                self.collided[b] = True
            out.append(Collision(self.steps, a, b, kind))
        return out
