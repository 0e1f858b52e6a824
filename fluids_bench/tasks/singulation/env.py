"""Singulation-v0: push one of four clustered polygons clear of the others (source ch. 5)."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import shapely
from gymnasium import spaces

from fluids_bench.core.actions import check_action
from fluids_bench.core.snapshot import SnapshotMixin
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.core.validation import (
    as_seed,
    check_choice,
    check_float,
    check_int,
    fail,
    reject_unknown_kwargs,
)
from fluids_bench.tasks.singulation import render
from fluids_bench.tasks.singulation.sim import (
    MAX_DR,
    MAX_DTHETA,
    NUM_OBJECTS,
    OBJECT_SIZE_SCALES,
    SceneConfig,
    SingulationWorld,
    sample_cluster,
)
from fluids_bench.tasks.singulation.supervisor import SingulationSupervisor

WHERE = "Singulation-v0"
OBS_TYPES = ("state", "pixels")
STATE_SIZE = 2 + 4 * NUM_OBJECTS
RESET_STATE_SIZE = 2 + 3 * NUM_OBJECTS


# Objects given to reset may overlap by at most this share of the smaller one's area (pymunk
# separates a slight overlap; a deep one, or objects at one point, explodes or sticks).
MAX_OVERLAP = 0.05


def _check_reset_state(c: SceneConfig, state: Any) -> tuple[float, float, np.ndarray]:
    """`options["state"]` as (theta, r, poses), or a ValueError saying what is wrong: the arm
    within its joint limits, every object's centre on the table, no two objects overlapping."""
    name = "options['state']"
    values = np.asarray(state) if not isinstance(state, str) else np.asarray([])
    if values.dtype.kind not in "iuf" or values.shape != (RESET_STATE_SIZE,):
        fail(
            WHERE, name, state, f"{RESET_STATE_SIZE} real numbers [theta, r, x_0, y_0, phi_0, ...]"
        )
    values = values.astype(np.float64)
    if not np.isfinite(values).all():
        fail(WHERE, name, state, f"{RESET_STATE_SIZE} finite numbers")
    theta, r = float(values[0]), float(values[1])
    check_float(WHERE, "options['state'] theta", theta, c.theta_min, c.theta_max)
    check_float(WHERE, "options['state'] r", r, c.r_min, c.r_max)
    poses = values[2:].reshape(NUM_OBJECTS, 3)
    half = c.table_width / 2
    polygons = []
    for i, (x, y, phi) in enumerate(poses):
        if not (-half <= x <= half and 0.0 <= y <= c.table_depth):
            fail(
                WHERE,
                f"options['state'] object {i} centre",
                (float(x), float(y)),
                f"on the table: x in [{-half}, {half}] m, y in [0, {c.table_depth}] m",
            )
        rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
        polygons.append(shapely.Polygon(c.shapes[i] @ rot.T + (x, y)))
    for i in range(NUM_OBJECTS):
        for j in range(i + 1, NUM_OBJECTS):
            shared = polygons[i].intersection(polygons[j]).area
            if shared > MAX_OVERLAP * min(polygons[i].area, polygons[j].area):
                fail(
                    WHERE,
                    f"options['state'] objects {i} and {j}",
                    f"overlapping by {shared:.3g} m^2",
                    f"objects that overlap by at most {MAX_OVERLAP:.0%} of the smaller's area",
                )
    return theta, r, poses


class SingulationEnv(SnapshotMixin, gym.Env):
    """
    ## Description

    The singulation task of the source's ch. 5: four convex polygons of about 10 cm and
    uniform density lie packed touching on a table; a planar arm at the table's near edge
    (base rotation and extension, only its fingertip touching the table) must push them until
    one object's centre is at least 10 cm from every other object's centre (with
    `object_size_scale` s: objects of about 10 s cm, singulated at 10 s cm). Pushing is
    quasi-static (pymunk 7, no gravity, damping 0: objects move only while pushed). The
    supervisor (`fluids_bench.tasks.singulation.supervisor`) is hierarchical: it picks the
    object and push direction by simulating candidate pushes on a rebuilt world, routes the
    fingertip around the objects to the pre-push point, then pushes.

    ## Action Space

    `Box(-1, 1, (2,), float32)`: `[a_rot, a_ext]`, the joint change this step as a fraction of
    the limits: base rotation `a_rot × 1.5°` and extension `a_ext × 1 cm`. Actions outside
    [-1, 1] are clipped; the resulting pose is clipped to the joint limits (rotation
    [30°, 150°] from +x, extension [0.12, 0.78] m). The fingertip reaches the commanded pose by
    the end of the step (10 physics substeps, 0.1 s).

    ## Observation Space

    `obs_type="state"`: `Box((18,), float32)`: `[theta, r, (x_i, y_i, sin phi_i, cos phi_i) for
    the 4 objects]`, arm pose in rad and m, object centroids in m (arm base at the origin, +y
    across the table, within ±1 m) and orientations. `obs_type="pixels"`: `Box(0, 255, (obs_size, obs_size,
    3), uint8)`, an overhead RGB picture (the source's webcam view) of the 0.8 m square in front
    of the arm. A list such as `["state", "pixels"]` gives a `Dict` with those keys.

    ## Rewards

    1.0 on the step the task is first solved, 0 otherwise, so an episode's return is its
    success.

    ## Starting State

    The arm at home (90°, 0.2 m). The cluster: objects placed one at a time in a random order,
    each with a uniform random orientation, slid in from a random direction until it touches
    the others; the cluster is rotated by U(-`cluster_rotation_deg`, +`cluster_rotation_deg`)
    and translated by an isotropic Gaussian of standard deviation `cluster_std` around
    (0, 0.45) m (clipped at 3 standard deviations). A draw that is already singulated is
    redrawn. `reset(options={"state": [theta, r, x_0, y_0, phi_0, ..., x_3, y_3, phi_3]})`
    starts from that exact state instead: the arm within its joint limits (30° to 150°, 0.12 to
    0.78 m), every object's centre on the table (x in [-0.5, 0.5] m, y in [0, 0.8] m) and no two
    objects overlapping by more than 5 % of the smaller's area; anything else is a ValueError.

    ## Episode End

    Termination when some object's centre is 10 cm × `object_size_scale` or more from every
    other object's centre (`info["is_success"]`, to 1 nm); with `terminate_on_success=False`
    the episode runs on. Truncation at 150 steps (the registration's `max_episode_steps`).
    `info["progress"]` is the continuous measure: the largest, over objects, of the distance
    (m) from its centre to the nearest other centre (success is progress ≥ 0.10 ×
    `object_size_scale`).

    ## Snapshots and labels

    `env.unwrapped.snapshot()` returns a picklable state; `restore(snapshot)` on another env
    built with the same kwargs (reset with any seed) continues bit-identically, labels
    included. The world is stored as its initial state and the joint commands since, and
    rebuilt by replaying them (a copy of pymunk's space is not bit-identical; a replay is);
    pickling or deep-copying the env does the same. The supervisor keeps a push plan between
    replans (the target object, the push line, the object poses it was planned for, whether
    the push has started, the approach route): the label is a function of the world and that
    plan, and the plan is part of the snapshot, so after `restore` `supervisor_action()`
    equals the label of the env that drove there. A supervisor built afresh on the same world
    replans at once and may choose another push.

    ## Arguments

    The keyword arguments of `__init__`, each described in its `Args:`. Numbers may be Python
    or numpy scalars; a bad value raises `ValueError` naming it and what is allowed, an
    unknown argument `TypeError` (also a `ValueError`) listing the allowed ones.

    ## Version History

    * v0: Initial version.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}
    RENDER_SIZE = 400

    # the world (its initial state and joint commands, replayed exactly when unpickled: pymunk
    # keeps contact impulses that no copy restores), the supervisor's push plan and _solved
    _snapshot_fields = ("_world", "_supervisor", "_solved")

    @reject_unknown_kwargs
    def __init__(
        self,
        obs_type: str | list[str] = "state",
        obs_size: int = 96,
        cluster_std: float = math.sqrt(0.002),
        cluster_rotation_deg: float = 15.0,
        terminate_on_success: bool = True,
        mass_ratio: float = 1.0,
        friction_scale: float = 1.0,
        object_size_scale: float = 1.0,
        render_mode: str | None = None,
    ) -> None:
        """Build the singulation task (the objects' cluster is drawn at each reset).

        Args:
            obs_type: `"state"`, `"pixels"`, or a list of them (a `Dict` space).
            obs_size: Side of the pixel observation, in pixels.
            cluster_std: Standard deviation of the cluster's translation (m); ch. 5's
                "variance of 20 cm" read as 20 cm².
            cluster_rotation_deg: Half-range of the cluster's rotation (degrees).
            terminate_on_success: End the episode when an object is singulated.
            mass_ratio: The heaviest object's mass over the lightest's: object i's density ×
                ratio^(i/3 − 1/2) (one common scale would change nothing: no gravity, no table
                friction); the supervisor's foresight simulates the same world.
            friction_scale: The objects' and the fingertip's friction (0.5) × this.
            object_size_scale: Every object's lengths × this (density kept); the
                singulation distance (10 cm) scales with it, so packed clusters never start
                singulated.
            render_mode: `None` or `"rgb_array"` (400×400).
        """
        kinds = [obs_type] if isinstance(obs_type, str) else obs_type
        if not isinstance(kinds, list | tuple) or not kinds or len(set(kinds)) != len(kinds):
            fail(WHERE, "obs_type", obs_type, f"one of {list(OBS_TYPES)} or a list of them")
        for kind in kinds:
            check_choice(WHERE, "obs_type", kind, OBS_TYPES)
        self.obs_kinds = tuple(kinds)
        self.dict_obs = not isinstance(obs_type, str)
        self.obs_size = check_int(WHERE, "obs_size", obs_size, 16, 512)
        self.config = SceneConfig(
            cluster_std=check_float(WHERE, "cluster_std", cluster_std, 0.0, 0.2),
            cluster_rotation=math.radians(
                check_float(WHERE, "cluster_rotation_deg", cluster_rotation_deg, 0.0, 180.0)
            ),
            mass_ratio=check_float(WHERE, "mass_ratio", mass_ratio, 1.0, 100.0),
            friction_scale=check_float(WHERE, "friction_scale", friction_scale, 0.0, 4.0),
            object_size_scale=check_float(
                WHERE, "object_size_scale", object_size_scale, *OBJECT_SIZE_SCALES
            ),
        )
        if not isinstance(terminate_on_success, bool | np.bool_):
            fail(WHERE, "terminate_on_success", terminate_on_success, "True or False")
        self.terminate_on_success = bool(terminate_on_success)
        self.render_mode = check_choice(WHERE, "render_mode", render_mode, [None, "rgb_array"])

        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        c = self.config
        # no object can be pushed beyond the fingertip's reach plus its own size: |x|, |y| < 1 m
        low = np.full(STATE_SIZE, -1.0, np.float32)
        high = np.full(STATE_SIZE, 1.0, np.float32)
        low[:2], high[:2] = (c.theta_min, c.r_min), (c.theta_max, c.r_max)
        low[4::4] = low[5::4] = -1.0
        high[4::4] = high[5::4] = 1.0
        parts = {
            "state": spaces.Box(low, high, (STATE_SIZE,), np.float32),
            "pixels": spaces.Box(0, 255, (self.obs_size, self.obs_size, 3), np.uint8),
        }
        if self.dict_obs:
            self.observation_space = spaces.Dict({k: parts[k] for k in self.obs_kinds})
        else:
            self.observation_space = parts[self.obs_kinds[0]]
        self._world: SingulationWorld | None = None
        self._supervisor = SingulationSupervisor()
        self._solved = False

    # -- the supervisor ------------------------------------------------------------------

    def supervisor_action(self) -> np.ndarray:
        """The supervisor's normalised action in the current state."""
        if self._world is None:
            raise RuntimeError(f"{WHERE}: call reset() before asking for the supervisor's action")
        return self._supervisor.action(self._world)

    def supervisor_stats(self) -> dict[str, float]:
        """Behaviour-level replans since the last reset and the time they took (s, wall clock)."""
        return {
            "replans": self._supervisor.replans,
            "replan_seconds": self._supervisor.replan_seconds,
        }

    @property
    def world(self) -> SingulationWorld:
        """The simulator (read it, do not step it)."""
        if self._world is None:
            raise RuntimeError(f"{WHERE}: call reset() first")
        return self._world

    # -- observations ----------------------------------------------------------------------

    def _state(self) -> np.ndarray:
        w = self._world
        poses = w.poses()
        out = np.empty(STATE_SIZE, np.float32)
        out[0], out[1] = w.theta, w.r
        out[2::4], out[3::4] = poses[:, 0], poses[:, 1]
        out[4::4], out[5::4] = np.sin(poses[:, 2]), np.cos(poses[:, 2])
        return out

    def _observation(self) -> Any:
        parts = {}
        for kind in self.obs_kinds:
            if kind == "state":
                parts[kind] = self._state()
            else:
                parts[kind] = render.draw(self._world, self.obs_size)
        return parts if self.dict_obs else parts[self.obs_kinds[0]]

    def _info(self) -> dict[str, Any]:
        progress = self._world.progress()
        return {
            "is_success": bool(self._world.is_singulated()),
            "progress": progress,
            SUPERVISOR_ACTION_KEY: self.supervisor_action(),
        }

    # -- the API ---------------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        seed = as_seed(seed)  # np.int64(5) seeds as 5
        super().reset(seed=seed)
        c = self.config
        if options is not None and (not isinstance(options, dict) or set(options) - {"state"}):
            fail(WHERE, "options", options, "None or a dict with the optional key 'state'")
        state = None if options is None else options.get("state")
        if state is None:
            theta, r = c.home_theta, c.home_r
            poses = sample_cluster(c, self.np_random)
        else:
            theta, r, poses = _check_reset_state(c, state)
        self._world = SingulationWorld(c, theta, r, poses)
        self._supervisor = SingulationSupervisor()
        self._solved = False
        return self._observation(), self._info()

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        if self._world is None:
            raise RuntimeError(f"{WHERE}: call reset() before step()")
        a = check_action(WHERE, self.action_space, action)
        a0 = min(max(float(a[0]), -1.0), 1.0)
        a1 = min(max(float(a[1]), -1.0), 1.0)
        self._world.step(a0 * MAX_DTHETA, a1 * MAX_DR)
        info = self._info()
        reward = 0.0
        if info["is_success"] and not self._solved:
            reward, self._solved = 1.0, True
        terminated = self.terminate_on_success and info["is_success"]
        return self._observation(), reward, terminated, False, info

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array" or self._world is None:
            return None
        return render.draw(self._world, self.RENDER_SIZE)
