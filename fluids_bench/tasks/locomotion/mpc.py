"""Predictive-sampling MPC on MuJoCo's own model, through `mujoco.rollout`.

The planner clones the env's full physics state (`mjSTATE_FULLPHYSICS` plus
`qacc_warmstart`), so its rollouts reproduce `env.step` bit for bit: a plan's predicted
return is the return the env would pay. Each label is planned from scratch ("cold"): the
nominal plan starts at zero and `iterations` rounds of predictive sampling refine it, each
round drawing `samples - 1` Gaussian perturbations of the nominal (plus the nominal itself)
and keeping the best; round `i` scales the noise by `sigma_decay**i`. With `knots` = K > 0
the perturbations are drawn at K knots and interpolated linearly over the horizon (a smaller
search space: what a cold start needs). The draws come from a generator seeded by `seed` and a CRC of the state
bytes, so the label is a pure function of the physics state: asking twice, or from the same
state reached another way, gives the same action.

The objective is the env's own reward over the horizon (forward progress, control cost,
healthy bonus with termination masking), plus planner-only shaping terms that are part of the
supervisor's definition and never change the env's reward:

* `upright_weight`: HalfCheetah: `w * max(|pitch| - 0.5, 0)^2` per step, which stops the
  planner from running on its back (the pure-reward optimum flips the cheetah over);
  Hopper/Walker2d: `w * ((z - z0)^2 + pitch^2)`; Humanoid: `w * (z - z0)^2`.
* `velocity_cap`: forward speed above this earns nothing (Humanoid: falls come from
  sprinting);
* `termination_penalty`: a one-off cost when the horizon's state leaves the healthy set, and
  the shaping costs keep accruing after it, so dying early is never the cheap option.

With a `prior` (a policy mapping the physics state to an action), the first nominal is the
prior's own closed-loop plan from the current state (simulated on a scratch copy), so the search
refines a plan that already walks instead of starting from standing still; a pure function of
the state too.

Reference: MJPC's predictive sampling (Howell et al. 2022); measured settings in the README.
"""

from __future__ import annotations

import zlib
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco import rollout

from fluids_bench.core.validation import check_choice, check_float, check_int

TASKS = ("Hopper", "Walker2d", "HalfCheetah", "Humanoid")

# Copies of Gymnasium's v5 defaults (the env's reward), per task.
_REWARD = {
    "Hopper": dict(forward=1.0, ctrl=1e-3, healthy=1.0),
    "Walker2d": dict(forward=1.0, ctrl=1e-3, healthy=1.0),
    "HalfCheetah": dict(forward=1.0, ctrl=0.1, healthy=0.0),
    "Humanoid": dict(forward=1.25, ctrl=0.1, healthy=5.0),
}
_STAND_Z = {"Hopper": 1.25, "Walker2d": 1.25, "HalfCheetah": 0.0, "Humanoid": 1.4}


@dataclass(frozen=True, kw_only=True)
class MPCConfig:
    """Settings of `SamplingMPC` (`horizon` in env steps; `sigma` in half action ranges)."""

    task: str
    samples: int = 128
    horizon: int = 20
    iterations: int = 1
    sigma: float = 0.8
    sigma_decay: float = 1.0
    knots: int = 0
    upright_weight: float = 0.0
    velocity_cap: float = float("inf")
    termination_penalty: float = 0.0
    seed: int = 0
    nthread: int = 1

    def __post_init__(self) -> None:
        where = type(self).__name__
        check_choice(where, "task", self.task, TASKS)
        check_int(where, "samples", self.samples, 1, 100_000)
        check_int(where, "horizon", self.horizon, 1, 10_000)
        check_int(where, "iterations", self.iterations, 1, 1_000)
        check_float(where, "sigma", self.sigma, 0.0, lo_open=True)
        check_int(where, "knots", self.knots, 0, self.horizon)
        check_float(where, "sigma_decay", self.sigma_decay, 0.0, 1.0, lo_open=True)
        check_float(where, "upright_weight", self.upright_weight, 0.0)
        if not (self.velocity_cap == float("inf")):
            check_float(where, "velocity_cap", self.velocity_cap, 0.0)
        check_float(where, "termination_penalty", self.termination_penalty, 0.0)
        check_int(where, "seed", self.seed, 0)
        check_int(where, "nthread", self.nthread, 0, 256)

    def as_dict(self) -> dict:
        d = dict(self.__dict__)
        d["velocity_cap"] = None if d["velocity_cap"] == float("inf") else d["velocity_cap"]
        return d


def planning_model(task: str, model: mujoco.MjModel, xml_path: str) -> mujoco.MjModel:
    """The model the planner rolls out: the env's own, plus (Humanoid) a centre-of-mass sensor.

    Humanoid's reward is the velocity of the mass centre, which is not part of the state; a
    `subtreecom` sensor on the root body reads it. Sensors do not change the dynamics.
    """
    if task != "Humanoid":
        return model
    spec = mujoco.MjSpec.from_file(xml_path)
    spec.add_sensor(
        type=mujoco.mjtSensor.mjSENS_SUBTREECOM, objtype=mujoco.mjtObj.mjOBJ_BODY, objname="torso"
    )
    planner = spec.compile()
    if planner.nq != model.nq or planner.nv != model.nv or planner.nu != model.nu:
        raise RuntimeError("Humanoid planning model does not match the env's model")
    return planner


class SamplingMPC:
    """Cold-started predictive sampling; `act(data)` is a pure function of `data`'s state."""

    def __init__(
        self,
        config: MPCConfig,
        model: mujoco.MjModel,
        frame_skip: int,
        xml_path: str = "",
        prior: Callable[[mujoco.MjData], np.ndarray] | None = None,
    ) -> None:
        self.config = config
        self.model = planning_model(config.task, model, xml_path)
        self.frame_skip = int(frame_skip)
        self.dt = self.model.opt.timestep * self.frame_skip
        lo, hi = self.model.actuator_ctrlrange.T
        self.ctrl_low, self.ctrl_high = lo.copy(), hi.copy()
        self.nstate = mujoco.mj_stateSize(self.model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        self.prior = prior
        if config.knots:
            # (H, K) matrix mapping knot values to per-step values (linear interpolation)
            t = np.linspace(0.0, config.knots - 1, config.horizon)
            self._interp = np.maximum(0.0, 1.0 - np.abs(t[:, None] - np.arange(config.knots)[None]))
        self._pool: rollout.Rollout | None = None
        self._scratch: mujoco.MjData | None = None

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_pool"] = None  # a thread pool does not pickle; it is rebuilt on first use
        state["_scratch"] = None
        return state

    def _rollout(self, x0: np.ndarray, warm: np.ndarray, controls: np.ndarray):
        cfg, m = self.config, self.model
        n = controls.shape[0]
        if self._pool is None:
            self._pool = rollout.Rollout(nthread=cfg.nthread)
            self._datas = [mujoco.MjData(m) for _ in range(max(1, cfg.nthread))]
        ctrl = np.repeat(controls, self.frame_skip, axis=1)
        state, sensor = self._pool.rollout(
            [m] * n,
            self._datas,
            np.repeat(x0[None], n, axis=0),
            ctrl,
            initial_warmstart=np.repeat(warm[None], n, axis=0),
        )
        return state, sensor

    def _returns(self, x0, state, sensor, controls) -> np.ndarray:
        """The planner's objective for each sampled plan (larger is better)."""
        cfg, task, fs = self.config, self.config.task, self.frame_skip
        w = _REWARD[task]
        m = self.model
        nq = m.nq
        post = state[:, fs - 1 :: fs]  # state after each env step
        qpos = post[:, :, 1 : 1 + nq]
        qvel = post[:, :, 1 + nq :]
        if task == "Humanoid":
            # centre of mass at the input of each physics step: take it at env-step boundaries
            com = sensor[:, ::fs, 0]  # (n, H): COM x before each env step
            x_next = np.concatenate([com[:, 1:], com[:, -1:]], axis=1)
            vel = (x_next - com) / self.dt
            vel[:, -1] = vel[:, -2] if vel.shape[1] > 1 else 0.0
        else:
            x_prev = np.concatenate([np.full((qpos.shape[0], 1), x0[1]), qpos[:, :-1, 0]], axis=1)
            vel = (qpos[:, :, 0] - x_prev) / self.dt
        vel = np.minimum(vel, cfg.velocity_cap)
        reward = w["forward"] * vel - w["ctrl"] * np.sum(controls**2, axis=2)
        healthy = self._healthy(qpos, qvel)
        alive = np.cumprod(healthy, axis=1)  # rewards stop after the first unhealthy step
        reward = reward * alive + w["healthy"] * alive
        total = reward.sum(axis=1)
        if cfg.termination_penalty > 0 and task != "HalfCheetah":
            total -= cfg.termination_penalty * (alive[:, -1] == 0)
        if cfg.upright_weight > 0:
            if task == "HalfCheetah":
                cost = np.maximum(np.abs(qpos[:, :, 2]) - 0.5, 0.0) ** 2
            elif task == "Humanoid":
                cost = (qpos[:, :, 2] - _STAND_Z[task]) ** 2
            else:
                cost = (qpos[:, :, 1] - _STAND_Z[task]) ** 2 + qpos[:, :, 2] ** 2
            total -= cfg.upright_weight * cost.sum(axis=1)
        return total

    def _healthy(self, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        task = self.config.task
        if task == "HalfCheetah":
            return np.ones(qpos.shape[:2])
        if task == "Humanoid":
            return ((qpos[..., 2] > 1.0) & (qpos[..., 2] < 2.0)).astype(float)
        z, angle = qpos[..., 1], qpos[..., 2]
        if task == "Hopper":
            rest = np.concatenate([qpos[..., 2:], qvel], axis=-1)
            ok = np.all(np.abs(rest) < 100.0, axis=-1) & (z > 0.7) & (np.abs(angle) < 0.2)
        else:
            ok = (z > 0.8) & (z < 2.0) & (np.abs(angle) < 1.0)
        return ok.astype(float)

    def act(self, data: mujoco.MjData) -> np.ndarray:
        """The planned first action from `data`'s physics state (pure function of the state)."""
        cfg = self.config
        x0 = np.empty(self.nstate)
        mujoco.mj_getState(self.model, data, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        warm = np.array(data.qacc_warmstart, dtype=np.float64)
        key = zlib.crc32(x0.tobytes() + warm.tobytes())
        rng = np.random.default_rng([cfg.seed, key])
        nu = self.model.nu
        half = (self.ctrl_high - self.ctrl_low) / 2
        mid = (self.ctrl_high + self.ctrl_low) / 2
        if self.prior is None:
            nominal = np.broadcast_to(mid, (cfg.horizon, nu)).copy()
        else:
            nominal = self._prior_plan(data, x0, warm)
        for i in range(cfg.iterations):
            scale = cfg.sigma * cfg.sigma_decay**i * half  # later rounds search closer
            if cfg.knots:  # smooth perturbations: Gaussian at knots, linear in between
                noise = np.einsum(
                    "hk,skn->shn", self._interp, rng.standard_normal((cfg.samples, cfg.knots, nu))
                )
                noise *= scale
            else:
                noise = rng.standard_normal((cfg.samples, cfg.horizon, nu)) * scale
            noise[0] = 0.0  # candidate 0 re-evaluates the nominal: never worse than last round
            controls = np.clip(nominal[None] + noise, self.ctrl_low, self.ctrl_high)
            state, sensor = self._rollout(x0, warm, controls)
            best = int(np.argmax(self._returns(x0, state, sensor, controls)))
            nominal = controls[best]
        return nominal[0].copy()

    def _prior_plan(self, data: mujoco.MjData, x0: np.ndarray, warm: np.ndarray) -> np.ndarray:
        """The prior policy's closed-loop actions over the horizon, simulated from `data`'s
        state `x0` (the first read from `data` itself: Humanoid's observation holds
        quantities the state alone does not set until the next step)."""
        m = self.model
        if self._scratch is None:
            self._scratch = mujoco.MjData(m)
        d = self._scratch
        mujoco.mj_setState(m, d, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        d.qacc_warmstart[:] = warm
        plan = np.empty((self.config.horizon, m.nu))
        source = data
        for k in range(self.config.horizon):
            plan[k] = np.clip(self.prior(source), self.ctrl_low, self.ctrl_high)
            d.ctrl[:] = plan[k]
            mujoco.mj_step(m, d, nstep=self.frame_skip)
            mujoco.mj_rnePostConstraint(m, d)  # contact forces, as Gymnasium's step computes
            source = d
        return plan
