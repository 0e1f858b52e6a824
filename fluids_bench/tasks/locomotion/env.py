"""Gymnasium's MuJoCo v5 locomotion envs with a supervisor: `<Name>-IL-v0`.

The physics, observations, rewards and terminations are Gymnasium's own `<Name>-v5` env,
unchanged: each IL env holds one and forwards `reset`/`step`/`render` to it, and only adds
the supervisor protocol (`supervisor_action()`, `info["supervisor_action"]`) and a record
of which supervisor labels (`metadata["supervisor"]`: kind, recipe, weights sha256).
`reset(seed=s)` gives exactly Gymnasium's initial state for seed `s`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import warnings
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium.envs.mujoco.half_cheetah_v5 import HalfCheetahEnv
from gymnasium.envs.mujoco.hopper_v5 import HopperEnv
from gymnasium.envs.mujoco.humanoid_v5 import HumanoidEnv
from gymnasium.envs.mujoco.walker2d_v5 import Walker2dEnv

from fluids_bench.core.actions import check_action
from fluids_bench.core.snapshot import SnapshotMixin
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.core.validation import (
    as_seed,
    check_choice,
    check_float,
    check_int,
    reject_unknown_kwargs,
)
from fluids_bench.tasks.locomotion.mpc import MPCConfig
from fluids_bench.tasks.locomotion.supervisors import KINDS, make_supervisor

_GYM_ENVS = {
    "Hopper": HopperEnv,
    "Walker2d": Walker2dEnv,
    "HalfCheetah": HalfCheetahEnv,
    "Humanoid": HumanoidEnv,
}

# The supervisor each id uses unless told otherwise (chosen by measurement: README).
DEFAULT_SUPERVISOR = {
    "Hopper": "policy",
    "Walker2d": "policy",
    "HalfCheetah": "policy",
    "Humanoid": "policy",
}

# Mean 1,000-step return of the source's TRPO experts (Ho & Ermon 2016), for comparison.
SOURCE_EXPERT_RETURN = {
    "Hopper": 3571.0,
    "Walker2d": 6717.0,
    "HalfCheetah": 4463.0,
    "Humanoid": 9575.0,
}

# Mean 1,000-step return of uniformly random actions over seeds 0-9 (measured: README), and of
# the default supervisor (measured by scripts/quality/locomotion_supervisor_quality.py: README).
RANDOM_RETURN = {"Hopper": 17.0, "Walker2d": 4.3, "HalfCheetah": -278.4, "Humanoid": 117.8}
# None: not measured over 10 episodes yet (then datasets carry no reference scores).
SUPERVISOR_RETURN: dict[str, float | None] = {
    "Hopper": 3158.1,
    "Walker2d": 4226.6,
    "HalfCheetah": 5115.2,
    "Humanoid": 7382.5,
}

# Gymnasium's half_cheetah.xml uses a compiler attribute MuJoCo now deprecates; the model is
# still compiled as Gymnasium intends, and nothing a user can change: dropped, see below.
_KNOWN_MUJOCO_WARNINGS = ("compiler attribute 'settotalmass' is deprecated",)


@contextlib.contextmanager
def _mujoco_warnings_to_python():
    """While building a model, route MuJoCo's warnings to Python's `warnings`: its default
    handler prints them and appends them to `MUJOCO_LOG.TXT` in the working directory, which
    every HalfCheetah build did (`settotalmass`). Known harmless ones are dropped."""

    def handler(message: str) -> None:
        if not message.startswith(_KNOWN_MUJOCO_WARNINGS):
            warnings.warn(f"MuJoCo: {message}", RuntimeWarning, stacklevel=2)

    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(handler)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)


_MPC_KEYS = tuple(f.name for f in dataclasses.fields(MPCConfig) if f.name != "task")
GRAVITY = 9.81  # m/s², Gymnasium's models (MuJoCo's default)


def perturb_model(
    model: mujoco.MjModel,
    body_mass_scale: float = 1.0,
    friction_scale: float = 1.0,
    actuator_gain_scale: float = 1.0,
    gravity: float = GRAVITY,
) -> None:
    """Change a compiled model in place (a sensitivity sweep's factors): every body's mass and
    inertia × `body_mass_scale`, every geom's sliding friction × `friction_scale`, every
    actuator's gear × `actuator_gain_scale`, gravity `-gravity` along z. The defaults leave
    the model untouched."""
    if body_mass_scale != 1.0:
        model.body_mass[:] *= body_mass_scale
        model.body_inertia[:] *= body_mass_scale
    if friction_scale != 1.0:
        model.geom_friction[:, 0] *= friction_scale
    if actuator_gain_scale != 1.0:
        model.actuator_gear[:, 0] *= actuator_gain_scale
    if gravity != GRAVITY:
        model.opt.gravity[:] = (0.0, 0.0, -gravity)


class LocomotionILEnv(SnapshotMixin, gym.Env[np.ndarray, np.ndarray]):
    """Base class of the four ids; subclasses set `task` and carry the env card."""

    task: str = ""
    metadata = {"render_modes": ["rgb_array"], "render_fps": 0}

    @reject_unknown_kwargs
    def __init__(
        self,
        supervisor: str | None = None,
        weights: str | None = None,
        weights_sha256: str | None = None,
        mpc: dict[str, Any] | None = None,
        render_mode: str | None = None,
        width: int = 480,
        height: int = 480,
        body_mass_scale: float = 1.0,
        friction_scale: float = 1.0,
        actuator_gain_scale: float = 1.0,
        gravity: float = GRAVITY,
        obs_noise: float = 0.0,
        action_noise: float = 0.0,
    ) -> None:
        """Build Gymnasium's env with its supervisor.

        Args:
            supervisor: Who labels: `"policy"`, `"mpc"` or `"guided_mpc"` (default: the
                task's measured best; see Supervisor).
            weights: Another weight file for the policy supervisor.
            weights_sha256: The SHA-256 of `weights`, checked at load.
            mpc: Overrides of the planner's settings (`samples`, `horizon`, `iterations`,
                `sigma`, `upright_weight`, `velocity_cap`, `termination_penalty`, `seed`,
                `nthread`).
            render_mode: `None` or `"rgb_array"`.
            width: Width of `render()` frames, in pixels.
            height: Height of `render()` frames, in pixels.
            body_mass_scale: A perturbation: every body's mass and inertia × this (default 1).
            friction_scale: A perturbation: every geom's sliding friction × this (default 1).
            actuator_gain_scale: A perturbation: every actuator's gear × this (default 1).
            gravity: A perturbation: gravity in m/s², downward (default 9.81).
            obs_noise: N(0, σ²) added to each observation element the learner sees (default
                0); the supervisor labels from the noiseless state; drawn from the env's
                `np_random`.
            action_noise: N(0, σ²) added to each action before it is applied, clipped to the
                action space (default 0); drawn from the env's `np_random`.
        """
        where = self._where = f"{self.task}-IL-v0"
        physics = {
            "body_mass_scale": check_float(where, "body_mass_scale", body_mass_scale, 0.1, 10.0),
            "friction_scale": check_float(where, "friction_scale", friction_scale, 0.0, 10.0),
            "actuator_gain_scale": check_float(
                where, "actuator_gain_scale", actuator_gain_scale, 0.0, 10.0
            ),
            "gravity": check_float(where, "gravity", gravity, 0.0, 100.0),
        }
        self.obs_noise = check_float(where, "obs_noise", obs_noise, 0.0, 10.0)
        self.action_noise = check_float(where, "action_noise", action_noise, 0.0, 10.0)
        kind = DEFAULT_SUPERVISOR[self.task] if supervisor is None else supervisor
        check_choice(where, "supervisor", kind, KINDS)
        check_choice(where, "render_mode", render_mode, [None, "rgb_array"])
        check_int(where, "width", width, 16, 4096)
        check_int(where, "height", height, 16, 4096)
        if mpc is not None:
            if kind == "policy":
                raise ValueError(
                    f"{where}: field 'mpc' is {mpc!r} with supervisor 'policy'; allowed: None, "
                    "or planner settings with supervisor 'mpc' or 'guided_mpc'"
                )
            if not isinstance(mpc, dict):
                raise ValueError(
                    f"{where}: field 'mpc' is {mpc!r}; allowed: a dict of planner settings"
                )
            for key in mpc:
                check_choice(where, "mpc key", key, _MPC_KEYS)
        if weights is not None and kind == "mpc":
            raise ValueError(
                f"{where}: field 'weights' is {weights!r} with supervisor 'mpc'; allowed: None, "
                "or a weight file with supervisor 'policy' or 'guided_mpc'"
            )
        if (weights is None) != (weights_sha256 is None):
            raise ValueError(
                f"{where}: field 'weights_sha256' is {weights_sha256!r} with weights {weights!r}; "
                "allowed: both given or both None"
            )
        if (
            render_mode == "rgb_array"
            and "MUJOCO_GL" not in os.environ
            and "DISPLAY" not in os.environ
        ):
            os.environ["MUJOCO_GL"] = "egl"  # headless: render off-screen through EGL
        self._kwargs = dict(
            supervisor=supervisor,
            weights=weights,
            weights_sha256=weights_sha256,
            mpc=mpc,
            render_mode=render_mode,
            width=width,
            height=height,
            **physics,
            obs_noise=obs_noise,
            action_noise=action_noise,
        )
        with _mujoco_warnings_to_python():  # models are compiled here (the planner's too)
            # the model's own com-tracking camera: Gymnasium's default one stays put sideways,
            # so a walker that drifts leaves the picture
            self._sim = _GYM_ENVS[self.task](
                render_mode=render_mode, width=width, height=height, camera_name="track"
            )
            # before the supervisor is built: a planner copies the model the env runs
            perturb_model(self._sim.model, **physics)
            self._supervisor = make_supervisor(
                self.task, kind, self._sim, weights, weights_sha256, mpc
            )
            # Humanoid's planner compiles its own copy of the model (with a sensor): perturb it
            planner = getattr(getattr(self._supervisor, "mpc", None), "model", None)
            if planner is not None and planner is not self._sim.model:
                perturb_model(planner, **physics)
        self.render_mode = render_mode
        self.observation_space = self._sim.observation_space
        self.action_space = self._sim.action_space
        self.metadata = {
            **type(self).metadata,
            "render_fps": self._sim.metadata["render_fps"],
            "gymnasium_env": f"{self.task}-v5",
            "mujoco_version": mujoco.__version__,
            "supervisor": self._supervisor.describe(),
            "source_expert_return": SOURCE_EXPERT_RETURN[self.task],
            # D4RL-style normalisation: (R - random) / (supervisor - random); the supervisor
            # figure is the default supervisor's, so it is None for another choice
            "reference_scores": {
                "random": RANDOM_RETURN[self.task],
                "supervisor": SUPERVISOR_RETURN[self.task]
                if kind == DEFAULT_SUPERVISOR[self.task] and weights is None and mpc is None
                else None,
            },
        }

    # -- supervisor protocol ---------------------------------------------------------------
    def supervisor_action(self) -> np.ndarray:
        """The supervisor's action in the current physics state (a pure function of it)."""
        return self._label(None)

    def _label(self, obs: np.ndarray | None) -> np.ndarray:
        # both kinds stay inside the bounds (tanh squashing; the planner clips its controls to
        # the actuator ranges, which are the action space's), so no clip is needed here
        label = self._supervisor.label(self._sim, obs)
        # the policy's label is float32 already (the action dtype): no astype call per step
        return label if label.dtype == np.float32 else label.astype(np.float32)

    # -- Gymnasium API ---------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        seed = as_seed(seed)  # np.int64(5) seeds as 5
        super().reset(seed=seed)
        obs, info = self._sim.reset(seed=seed, options=options)
        info[SUPERVISOR_ACTION_KEY] = self._label(obs)  # the oracle sees the noiseless state
        return self._observe(obs), info

    def step(self, action):
        action = check_action(self._where, self.action_space, action)
        space = self.action_space
        if self.action_noise > 0.0:  # actuation noise, from this env's np_random
            noise = self.np_random.normal(0.0, self.action_noise, action.shape)
            action = np.clip(action + noise, space.low, space.high).astype(space.dtype)
        else:
            # MuJoCo clamps controls to the actuators' ranges (the space's bounds), but
            # Gymnasium's v5 envs charge the control cost of the action as given: 1e155 gave a
            # reward of -inf. Clipped here, an action is charged as it is applied; inside the
            # space nothing changes, bit for bit.
            action = np.clip(action, space.low, space.high)
        obs, reward, terminated, truncated, info = self._sim.step(action)
        info[SUPERVISOR_ACTION_KEY] = self._label(obs)
        return self._observe(obs), float(reward), terminated, truncated, info

    def _observe(self, obs: np.ndarray) -> np.ndarray:
        """What the learner sees: Gymnasium's observation plus N(0, obs_noise²) per element."""
        if self.obs_noise > 0.0:
            noise = self.np_random.normal(0.0, self.obs_noise, obs.shape)
            obs = (obs + noise).astype(obs.dtype)
        return obs

    def render(self):
        if self.render_mode == "rgb_array":
            # Gymnasium's camera stays put and the runners leave the frame: follow the torso
            viewer = self._sim.mujoco_renderer._get_viewer(self.render_mode)
            viewer.cam.lookat[0] = self._sim.data.xpos[1, 0]
        return self._sim.render()

    def close(self) -> None:
        self._sim.close()

    # -- snapshots: the whole MjData, not only the physics state ----------------------------
    # Gymnasium's observation (Humanoid's cinert, cvel, qfrc_actuator, cfrc_ext) carries
    # quantities MuJoCo computed before the last integration step, so they are not a function
    # of (qpos, qvel): setting a fresh env's physics state and calling mj_forward gives other
    # numbers, and another label. The snapshot holds a copy of the whole MjData (state, warm
    # start, every derived field) and restore copies it into this env's MjData.
    # The MjData is stored as MuJoCo's own binary serialisation (plain bytes, parsed and
    # checked by MuJoCo, never unpickled) and must fit this env's model.
    def _snapshot_state(self) -> dict[str, Any]:
        return {
            **super()._snapshot_state(),
            "data": self._sim.data.__getstate__(),
            "sim_rng": (self._sim._np_random, self._sim._np_random_seed),
        }

    def _restore_state(self, state: dict[str, Any]) -> None:
        data = _mjdata(state.pop("data"), self._sim.model)
        self._sim._np_random, self._sim._np_random_seed = state.pop("sim_rng")
        super()._restore_state(state)
        mujoco.mj_copyData(self._sim.data, self._sim.model, data)

    # -- pickling: rebuild from kwargs, then restore the exact physics state -----------------
    def __getstate__(self) -> dict[str, Any]:
        return {
            "kwargs": self._kwargs,
            "data": self._sim.data,  # MjData pickles whole (state, warm start, derived fields)
            "sim_rng": self._sim.np_random.bit_generator.state if self._sim._np_random else None,
            "rng": self._np_random.bit_generator.state if self._np_random else None,
        }

    def __setstate__(self, state: dict[str, Any]) -> None:
        type(self).__init__(self, **state["kwargs"])
        sim = self._sim
        saved = state["data"]
        sim.data = saved  # the renderer keeps its own reference: point it at the restored data
        if hasattr(sim, "mujoco_renderer"):
            sim.mujoco_renderer.data = saved
        if state["sim_rng"] is not None:
            sim.np_random.bit_generator.state = state["sim_rng"]
        if state["rng"] is not None:
            self.np_random.bit_generator.state = state["rng"]


_CARD_COMMON = """
    ## Supervisor

    `supervisor` chooses who labels: `"policy"` (the shipped network for this task,
    `fluids_bench/tasks/locomotion/weights/`, sha256-checked at load; microseconds per label),
    `"mpc"` (predictive sampling on the exact MuJoCo model, planned from scratch for every
    label; its cost is stated in `metadata["supervisor"]["label_cost"]`) or `"guided_mpc"`
    (the same search started from the policy's plan). Every label is a deterministic function of
    the physics state. `metadata["supervisor"]` records the kind, recipe and weights hash.

    ## Snapshots and labels

    `env.unwrapped.snapshot()` returns a picklable state (the whole `MjData`, Gymnasium's and
    this env's `np_random`); `restore(snapshot)` on another env built with the same kwargs
    (reset with any seed) continues bit-identically, labels included. The whole `MjData` is
    needed, not only `qpos`/`qvel`: the observation (and so the policy's label) reads fields
    MuJoCo computed before the last integration step (Humanoid's `cinert`, `cvel`,
    `qfrc_actuator`, `cfrc_ext`), which a fresh env set to the same `qpos`/`qvel` recomputes
    differently. The label is a function of that `MjData`.

    ## Arguments

    The keyword arguments of `__init__`, each described in its `Args:`. The perturbations
    (a sensitivity sweep's factors) leave Gymnasium's env as it is, bit for bit, at their
    defaults, and are applied to the compiled model before the supervisor is built (a planner
    plans on the perturbed model; the shipped policy was trained on the nominal one). Numbers
    may be Python or numpy scalars; a bad value raises `ValueError` naming it and what is
    allowed, an unknown argument `TypeError` (also a `ValueError`) listing the allowed ones.

    ## Version History

    - v0: Gymnasium's v5 env with a supervisor.
"""


def _card(name: str, summary: str) -> str:
    return (
        f"""
    ## Description

    Gymnasium's `{name}-v5` (MuJoCo), unchanged, with a supervisor. {summary}

    ## Action Space, Observation Space, Rewards, Starting State, Episode End

    Exactly those of Gymnasium's `{name}-v5` with its default arguments (see its docs);
    `max_episode_steps` is 1000 as there. One difference: an action outside the action space
    is clipped to it before it is applied, so its control cost is that of the control MuJoCo
    applies (Gymnasium's env charges the unclipped action: `1e155` gave a reward of `-inf`).
    NaN and infinite actions are refused.
"""
        + _CARD_COMMON
    )


class HopperILEnv(LocomotionILEnv):
    __doc__ = _card(
        "Hopper",
        "A one-legged planar hopper must hop forward without falling. Default supervisor: "
        "the shipped ARS policy, fine-tuned under action noise (3,158 ± 7 over 10 seeded "
        "1,000-step episodes, no falls; 3,131 with N(0, 0.1^2) added to every action, no falls).",
    )
    task = "Hopper"


class Walker2dILEnv(LocomotionILEnv):
    __doc__ = _card(
        "Walker2d",
        "A planar biped must walk forward without falling. Default supervisor: the shipped "
        "ARS policy, fine-tuned under action noise (4,227 ± 24 over 10 seeded 1,000-step "
        "episodes, no falls; 4,079 with N(0, 0.1^2) added to every action, no falls).",
    )
    task = "Walker2d"


class HalfCheetahILEnv(LocomotionILEnv):
    __doc__ = _card(
        "HalfCheetah",
        "A planar cat-like runner must run forward fast (no falls). Default supervisor: the "
        "shipped ARS policy, fine-tuned under action noise (5,115 ± 30 over 10 seeded "
        "1,000-step episodes; 4,525 with N(0, 0.1^2) added to every action).",
    )
    task = "HalfCheetah"


class HumanoidILEnv(LocomotionILEnv):
    __doc__ = _card(
        "Humanoid",
        "A 3D humanoid must walk forward without falling. Default supervisor: the shipped "
        "ARS policy (7,383 ± 474 over 10 seeded 1,000-step episodes, one of which falls at "
        "step 826). It is brittle under action noise: N(0, 0.05^2) makes it fall in every "
        "episode (the actions range over [-0.4, 0.4]). Development builds before this policy "
        "shipped defaulted to cold-start MPC, which fell within 100 steps.",
    )
    task = "Humanoid"


def _mjdata(raw: Any, model: mujoco.MjModel) -> mujoco.MjData:
    """The `MjData` in `raw` (MuJoCo's serialisation), refused with a clear error unless it
    is valid and of a model the size of `model`."""
    from fluids_bench.core.state_format import StateFormatError

    if not isinstance(raw, bytes):
        raise StateFormatError(
            f"state['data']: expected MuJoCo's MjData bytes, got {type(raw).__name__}"
        )
    data = mujoco.MjData.__new__(mujoco.MjData)
    try:
        data.__setstate__(raw)
    except Exception as error:  # MuJoCo's parser refuses damaged bytes
        raise StateFormatError(f"state['data']: not a valid MjData ({error})") from None
    for size in ("nq", "nv", "nu", "na", "nbody", "njnt", "ngeom", "nsensordata"):
        if getattr(data.model, size) != getattr(model, size):
            raise StateFormatError(
                f"state['data']: an MjData of another model ({size} {getattr(data.model, size)}, "
                f"this env's {getattr(model, size)})"
            )
    return data
