"""GraspingInClutter-v0: push-grasping a target among obstacles with a planar 4-DOF arm (ch. 6)."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
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
from fluids_bench.tasks.grasping.render import draw
from fluids_bench.tasks.grasping.sim import (
    N_OBJECTS,
    TARGET,
    GraspConfig,
    GraspWorld,
    sample_scene,
)
from fluids_bench.tasks.grasping.supervisor import GraspSupervisor

WHERE = "GraspingInClutter-v0"
OBS_TYPES = ("state", "pixels")
STATE_DIM = 3 * N_OBJECTS + 3 + 1
GRASP_REWARD = 10.0  # the source's weight of the grasp in its cost
POSITION_BOUND = 2.0  # m: |x|, |y| of any object in the state observation (the table is < 1 m)
# where an obstacle left out by ``obstacles < 5`` lies: off the table, behind the arm's base
ABSENT_POSE = (0.0, -0.5, 0.0)


class GraspingInClutterEnv(SnapshotMixin, gym.Env):
    """
    ## Description

    A top-down table (0.70 m wide, 0.60 m deep) with a planar arm on the middle of its near edge:
    three revolute joints and a parallel-jaw gripper (the source's 4-DOF arm, ch. 6, simulated
    here with pymunk 7 instead of Box2D). Six boxes lie on the table: one target (green) and five
    obstacles (red) around it. The arm must grasp the target without knocking anything off the
    table. Links, palm and fingers collide with the boxes and push them (quasi-statically: a box
    stops as soon as nothing pushes it). A box whose centre leaves the table is knocked off and
    removed, counted once.

    The supervisor (`supervisor_action()`, `info["supervisor_action"]`) is hierarchical: it picks
    an approach corridor to the target by simulating the best-ranked candidates on worlds
    rebuilt from the objects with the arm at rest, follows its waypoints (retract, transit,
    approach, advance, close) and steers the end effector toward the current one, proportionally
    to the distance (see `fluids_bench.tasks.grasping.supervisor`). Its label is a function of
    the current state alone.

    ## Action Space

    `Box([-1, -1, 0], [1, 1, 1], (3,), float32)`, as the source's joystick:

    - 0, 1: end-effector velocity `(vx, vy)`, scaled by 0.25 m/s. The joints follow by a
      Jacobian-transpose controller; the arm's redundant degree of freedom makes the gripper
      trail its motion like a caster (it turns toward the direction of motion, and holds its
      heading when backing up). Joint speeds are limited to 3 rad/s and angles to their limits.
    - 2: gripper command: >= 0.5 closes the jaws, < 0.5 opens them (0.4 s from open to closed);
      closing jaws stop on whatever lies between them.

    `action_scale="normalized"` (`GraspingInClutter-v1`): `Box(-1, 1, (3,), float32)`, the same
    velocities; the gripper command is `2g - 1` (>= 0 closes the jaws). The supervisor's label
    is given in the same units.

    ## Observation Space

    `obs_type="state"` (default): `Box((22,), float32)`, as the source: for each box, target
    first, its pose `(x, y, rotation)` in metres and radians (rotation wrapped to [-pi, pi));
    then the three joint angles (relative, radians) and the gripper position in [0, 1]
    (0 open, 1 closed). A knocked-off box keeps the pose at which it left the table.

    `obs_type="pixels"`: `Box(0, 255, (S, S, 3), uint8)` with `S = obs_size`: the overhead
    picture of the table, drawn with OpenCV at that size.

    A list of types (e.g. `["state", "pixels"]`) gives a `Dict` space keyed by type.

    ## Rewards

    +10 when the target is grasped and -1 for every box knocked off, so an episode's return is
    `10 - cost` with the source's cost = boxes knocked off + 10 × (target not grasped).
    `info["cost"]` carries the cost so far, `info["is_success"]` is grasped with nothing knocked
    off. A grasp registers only when the gripper is commanded closed, the target's centre is
    between the fingers and the jaws have closed onto it.

    ## Starting State

    The arm at its home pose (grasp centre 0.22 m in front of the base, gripper open and pointing
    away from the base). The target's centre is drawn from an isotropic Gaussian around (0, 0.44)
    with a standard deviation of `target_std_frac` × the table's width (3%, the source's
    setting), its rotation uniformly in [-45°, 45°]; each obstacle at a uniform bearing and a
    distance of 8.5–15 cm from the target, without overlaps and 3 cm inside the table's edge.
    With `layout_seed`, the obstacles (and the target's rotation) form one fixed layout drawn
    from that seed and only the target's position is resampled each reset (redrawn while it
    would overlap an obstacle): the protocol of the source's SHIV experiment.

    ## Episode End

    Terminated when the target is grasped or knocked off. Truncated after 100 steps of 0.1 s
    (`max_episode_steps` of the registration); the supervisor needs about 30.

    ## Snapshots and labels

    `env.unwrapped.snapshot()` returns a picklable state (the world, the supervisor's plan
    cache and `np_random`); `restore(snapshot)` on another env built with the same kwargs
    (reset with any seed) continues bit-identically, labels included. The supervisor's cached
    corridor plan is keyed by the world state it was planned for, so the label is a function
    of the world.

    ## Arguments

    The keyword arguments of `__init__`, each described in its `Args:`. Numbers may be Python
    or numpy scalars; a bad value raises `ValueError` naming it and what is allowed, an
    unknown argument `TypeError` (also a `ValueError`) listing the allowed ones.

    ```python
    >>> import gymnasium as gym, fluids_bench
    >>> env = gym.make("GraspingInClutter-v0")
    >>> obs, info = env.reset(seed=0)
    >>> obs, reward, terminated, truncated, info = env.step(info["supervisor_action"])
    ```

    ## Version History

    * v1: `action_scale="normalized"`: a symmetric `[-1, 1]` action box (the gripper command
      shifted), what RL libraries expect; dynamics, rewards and success as v0.
    * v0: Initial version.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    # the world (its initial state and commands, replayed exactly when unpickled) and the
    # supervisor's plan cache, which is keyed by the world state it was made for
    _snapshot_fields = ("world", "supervisor", "_label")

    @reject_unknown_kwargs
    def __init__(
        self,
        obs_type: str | list[str] = "state",
        obs_size: int = 96,
        target_std_frac: float = 0.03,
        foresight: int = 7,
        layout_seed: int | None = None,
        render_size: int = 480,
        obstacle_size_scale: float = 1.0,
        friction: float = 0.5,
        obstacles: int = N_OBJECTS - 1,
        render_mode: str | None = None,
        action_scale: str = "physical",
    ) -> None:
        """Build the grasping task (the obstacles are drawn at each reset unless
        `layout_seed` fixes them).

        Args:
            obs_type: `"state"`, `"pixels"`, or a list of them (a `Dict` space).
            obs_size: Side of the pixel observation, in pixels.
            target_std_frac: Standard deviation of the target's offset, as a fraction of the
                table's width.
            foresight: Corridors the supervisor simulates per plan.
            layout_seed: A fixed obstacle layout (see Starting State); `None`: a new one at
                each reset.
            render_size: Side of `render()` frames, in pixels.
            obstacle_size_scale: The obstacles' box sides, drawn in [4.0, 5.5] cm, × this
                (the target stays 4.5 cm; larger ones do not fit around it).
            friction: Friction coefficient of the boxes and the arm.
            obstacles: Obstacles on the table: the scene is drawn as with five and the last
                ones are left out, lying off the table at (0, -0.5) m (as a knocked-off box
                lies where it left); never counted as knocked off.
            render_mode: `None` or `"rgb_array"`.
            action_scale: `"physical"` or `"normalized"` (see Action Space).
        """
        types = [obs_type] if isinstance(obs_type, str) else obs_type
        if not isinstance(types, list | tuple) or not types or len(set(types)) != len(types):
            fail(WHERE, "obs_type", obs_type, f"one of {list(OBS_TYPES)} or a list of them")
        for t in types:
            check_choice(WHERE, "obs_type", t, OBS_TYPES)
        self.obs_types = list(types)
        self.dict_obs = not isinstance(obs_type, str)
        self.obs_size = check_int(WHERE, "obs_size", obs_size, 16, 512)
        std = check_float(WHERE, "target_std_frac", target_std_frac, 0.0, 0.2)
        self.foresight = check_int(WHERE, "foresight", foresight, 1, 7)
        self.layout_seed = (
            None if layout_seed is None else check_int(WHERE, "layout_seed", layout_seed, 0)
        )
        self.render_size = check_int(WHERE, "render_size", render_size, 64, 2048)
        self.render_mode = check_choice(WHERE, "render_mode", render_mode, [None, "rgb_array"])

        self.obstacles = check_int(WHERE, "obstacles", obstacles, 0, N_OBJECTS - 1)
        perturbed: dict[str, Any] = {}  # the defaults build GraspConfig's own values
        scale = check_float(WHERE, "obstacle_size_scale", obstacle_size_scale, 0.5, 1.25)
        if scale != 1.0:
            lo, hi = GraspConfig.object_size
            perturbed["object_size"] = (lo * scale, hi * scale)
        perturbed["friction"] = check_float(WHERE, "friction", friction, 0.0, 2.0)
        self.cfg = GraspConfig(target_std_frac=std, **perturbed)
        self.action_scale = check_choice(
            WHERE, "action_scale", action_scale, ["physical", "normalized"]
        )
        self.grip_low = 0.0 if self.action_scale == "physical" else -1.0
        self.action_space = spaces.Box(
            np.array([-1.0, -1.0, self.grip_low], np.float32), np.array([1.0, 1.0, 1.0], np.float32)
        )
        subspaces = {t: self._space(t) for t in self.obs_types}
        self.observation_space = (
            spaces.Dict(subspaces) if self.dict_obs else subspaces[self.obs_types[0]]
        )
        self.supervisor = GraspSupervisor(self.cfg, foresight=self.foresight)
        self.world: GraspWorld | None = None
        self._label: np.ndarray | None = None

    def _space(self, obs_type: str) -> spaces.Box:
        if obs_type == "pixels":
            return spaces.Box(0, 255, (self.obs_size, self.obs_size, 3), np.uint8)
        low = np.empty(STATE_DIM, np.float32)
        high = np.empty(STATE_DIM, np.float32)
        poses_low = np.tile([-POSITION_BOUND, -POSITION_BOUND, -math.pi], N_OBJECTS)
        poses_high = np.tile([POSITION_BOUND, POSITION_BOUND, math.pi], N_OBJECTS)
        low[: 3 * N_OBJECTS], high[: 3 * N_OBJECTS] = poses_low, poses_high
        limits = np.array(self.cfg.joint_limits)
        low[3 * N_OBJECTS : -1], high[3 * N_OBJECTS : -1] = limits[:, 0], limits[:, 1]
        low[-1], high[-1] = 0.0, 1.0
        return spaces.Box(low, high, dtype=np.float32)

    # -- the Gymnasium API -------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        seed = as_seed(seed)  # np.int64(5) seeds as 5
        super().reset(seed=seed)
        scene = sample_scene(self.cfg, self.np_random, self.layout_seed)
        if self.obstacles < N_OBJECTS - 1:  # the same draws; the last obstacles left out
            scene.on_table[1 + self.obstacles :] = False
            scene.poses[1 + self.obstacles :] = ABSENT_POSE
        self.world = GraspWorld(self.cfg, scene)
        self.supervisor.reset()
        self._label = None
        return self._observe(), self._info()

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        if self.world is None:
            raise RuntimeError(f"{WHERE}: call reset() before step()")
        a = check_action(WHERE, self.action_space, action)
        vx = min(1.0, max(-1.0, float(a[0]))) * self.cfg.max_speed
        vy = min(1.0, max(-1.0, float(a[1]))) * self.cfg.max_speed
        close = a[2] >= 0.5 if self.action_scale == "physical" else a[2] >= 0.0
        events = self.world.step(vx, vy, bool(close))
        self._label = None
        reward = GRASP_REWARD * events.grasped - float(events.newly_knocked)
        st = self.world.state
        terminated = st.grasped or not st.on_table[TARGET]
        return self._observe(), reward, terminated, False, self._info()

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn(
                'GraspingInClutterEnv.render() called without a render_mode; pass render_mode="rgb_array"'
            )
            return None
        if self.world is None:
            raise RuntimeError(f"{WHERE}: call reset() before render()")
        return draw(self.cfg, self.world.state, self.render_size)

    # -- supervisor protocol -----------------------------------------------------------------

    def supervisor_action(self) -> np.ndarray:
        """The supervisor's (vx, vy, grip) for the current state (computed once per state)."""
        if self.world is None:
            raise RuntimeError(f"{WHERE}: call reset() before supervisor_action()")
        if self._label is None:
            self._label = self.supervisor.action(self.world).astype(np.float32)
        label = self._label.copy()
        if self.action_scale == "normalized":  # the gripper command g in [0, 1] as 2g - 1
            label[2] = 2.0 * label[2] - 1.0
        return label

    def supervisor_stats(self) -> dict[str, float]:
        """Behaviour-level replans since the last reset and the CPU time they took (s)."""
        return {
            "replans": self.supervisor.replans,
            "replan_seconds": self.supervisor.replan_seconds,
        }

    # -- helpers -----------------------------------------------------------------------------

    def _state_obs(self) -> np.ndarray:
        st = self.world.state
        obs = np.empty(STATE_DIM, np.float32)
        poses = st.poses.copy()
        poses[:, 2] = (poses[:, 2] + math.pi) % (2 * math.pi) - math.pi
        obs[: 3 * N_OBJECTS] = poses.reshape(-1)
        obs[3 * N_OBJECTS : -1] = st.q
        obs[-1] = st.gripper
        return obs

    def _observe(self) -> Any:
        out = {}
        for t in self.obs_types:
            if t == "state":
                out[t] = self._state_obs()
            else:
                out[t] = draw(self.cfg, self.world.state, self.obs_size)
        return out if self.dict_obs else out[self.obs_types[0]]

    def _info(self) -> dict[str, Any]:
        w = self.world
        st = w.state
        return {
            SUPERVISOR_ACTION_KEY: self.supervisor_action(),
            "cost": float(w.cost()),
            "knocked_off": int(st.knocked),
            "grasped": bool(st.grasped),
            "is_success": bool(st.grasped and st.knocked == 0),
        }
