"""FLUIDS-v0: one ego car at a signalised urban intersection, everyone else supervised."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from fluids_bench.core.snapshot import SnapshotMixin
from fluids_bench.core.validation import as_seed
from fluids_bench.tasks.fluids import driving_score as scoring
from fluids_bench.tasks.fluids import levels
from fluids_bench.tasks.fluids.config import SINGLE_AGENT
from fluids_bench.tasks.fluids.core import actions as decode
from fluids_bench.tasks.fluids.core import infos, labels, rules
from fluids_bench.tasks.fluids.core.rules import Judged
from fluids_bench.tasks.fluids.observations import Observer
from fluids_bench.tasks.fluids.scenario import (
    build_scenario,
)
from fluids_bench.tasks.fluids.sim.entry import Entry
from fluids_bench.tasks.fluids.sim.fault import FaultTracker
from fluids_bench.tasks.fluids.sim.spawn import spawn
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor

# the rows `decode.act` decodes: the ego of the one world (none once it arrived), which steps
_EGO, _NO_ROW, _GOING = np.zeros(1, np.int64), np.zeros(0, np.int64), np.ones(1, np.bool_)


class FluidsEnv(SnapshotMixin, gym.Env):
    """
    ## Description
    FLUIDS (ch. 7 of the source dissertation): a first-order, multi-agent urban-intersection
    driving simulator. The learner drives the ego car through an intersection with traffic and
    crosswalk lights; background cars and pedestrians are driven by FLUIDS' four-level
    supervisor (behaviour → nominal trajectory → CSP velocity planner → PID control), which also
    labels every state the ego visits, at the level the learner acts at.

    ## Action Space
    Set by `action_level`; the supervisor fills the levels below it for the ego:

    * `"behavior"`: `Discrete(n)`: which movement (target lane) to take from the ego's entry
      lane, in counter-clockwise order of the exits (right, straight, left on a four-way); taken
      modulo the lane's count; ignored once the ego has reached the junction.
    * `"trajectory"`: `Box(-50, 50, (2K,))`: the next `K = waypoints` path points in the
      ego's frame (m, x forward, y left, flattened); the ego steers toward them.
    * `"velocity"`: `Box(0, v_max, (1,))`: the ego's target speed (m/s).
    * `"control"`: `Box(-1, 1, (2,))`: normalised [steering, force] (steering × max_steer
      rad; force × max_force when ≥ 0, × max_brake_force when < 0).

    `action_scale="normalized"` (the v2 ids): every Box level is `Box(-1, 1)`: the
    velocity level's `a` is the target speed `(a + 1) / 2 · v_max` m/s, the trajectory
    level's waypoints are `a · 50` m; control is unchanged. The supervisor's label is given
    in the same units (`info["supervisor_action"]` lies in the normalised space).

    Box actions are arrays of real numbers (ints or floats): out of bounds they are clipped;
    NaN or infinite values, strings (`"0.5"`), bools and complex numbers raise `ValueError`
    naming the level and the allowed form (they are never coerced).

    ## Observation Space
    `obs_type="explicit"`: `Box(-1000, 1000, (13 + 7k,), float32)` with `k = k_nearest`: the
    ego's state and goal, the k nearest agents in the ego's frame with a presence mask, and the
    ego's light (see `fluids_bench.tasks.fluids.sim.sensors.explicit`). `obs_noise` adds zero-mean
    Gaussian noise of that variance.

    `obs_type="birdseye"`: `Box(0, 255, (S, S, 3), uint8)` with `S = birdseye_size`: a
    top-down RGB image of the lanes, sidewalks, crosswalks, terrain, the light colours (a bar at
    each signalised stop line and crosswalk end), cars (blue), pedestrians (orange), the ego
    (magenta) and the ego's route (pink line). `birdseye_frame="ego"` centres a north-up square
    of side `birdseye_fov` m on the ego, `"ego_rotated"` also turns it so the ego faces up,
    `"global"` shows the whole layout (`birdseye_fov` unused). `pixel_noise` (λ_p) adds
    zero-mean Gaussian noise of that variance to every pixel value, clipped to [0, 255].

    `obs_type="qlidar"`: `Box((m, 4), float32)` with `m = lidar_rays`: ray `k` leaves the
    ego's centre at angle `2πk/m` from its heading (counter-clockwise) and reads
    `[d, label, ψ_r, v_r]`: the distance (m, `lidar_range` when nothing is hit), the label of
    what it hit (0 nothing, 1 car, 2 pedestrian, 3 road edge), that object's heading relative to
    the ego's (rad, in [-π, π]; a road edge's direction, in [-π/2, π/2)) and its speed minus the
    ego's (m/s, in ±2·v_max). `lidar_noise` (λ_l) adds zero-mean Gaussian noise of that
    variance to d, ψ_r and v_r; with probability `lidar_dropout` (ε) a ray reads as empty
    `[lidar_range, 0, 0, 0]`. See `fluids_bench.tasks.fluids.sim.sensors.qlidar`.

    `lidar_version=1` (the v1 ids): `Box((m + 1, 4), float32)`; rays also stop at the stop
    line of a red (label 4) or yellow (label 5) traffic light and at the edges of a crosswalk
    with a pedestrian on it (label 2), and row m is the goal row `[d, 6, bearing, −v_ego]` of
    the waypoint 5 m ahead on the ego's route (noise and dropout apply to the m rays only).

    A list of types (e.g. `["birdseye", "qlidar"]`) gives a `Dict` space keyed by type.

    `obs_scale="normalized"` (the v2 ids): the explicit and quasi-LIDAR observations become
    flat float32 vectors in `Box(-1, 1)` that an MLP policy can take as they are. Explicit
    (same length, same order): the ego's position relative to the layout's centre over half
    the layout's extent (86 m on the four-way), the goal's offset and the path left over the
    extent, the other agents' offsets and the distance to the stop line over 30 m (farther
    reads as ±1), speeds over the car's `max_speed`, cosines, sines, masks and one-hots
    unchanged, then clipped to ±1. Quasi-LIDAR: each row becomes `[d / lidar_range, ψ_r / π, v_r / (2 v_max)]` followed
    by a one-hot of its label (labels 1 … L−1; nothing hit is all zeros), rows concatenated:
    `(m + 1) · 9` values with `lidar_version=1` (585 for 64 rays). Noise is added before
    scaling. The bird's-eye image is unchanged (uint8, what image policies expect).

    ## Rewards
    `reward_version=0` (v0, v1): progress
    (`fluids_bench.tasks.fluids.core.rules.step_rewards`, the same in the multi-agent env):
    the metres of route gained this step divided by the route's length from the start (an
    episode that reaches the goal earns 1 in total), minus 1 in a step where the ego is in a
    collision. Running a red light or failing to yield fails `is_success` but costs nothing.

    `reward_version=1` (the v2 and v3 ids; the same function):
    a reward that agrees with `is_success`; every way to fail it costs, success pays. Per
    step, the sum of

    | term | weight | when |
    |---|---|---|
    | progress | +1 over the route | the route's metres gained this step over its length |
    | collision | −1 (v3: −3) | a step with a collision that fails the episode: the ego's with `done_when="ego"`, any with `"all"` |
    | red light | −1 (v3: −3) | the step the ego enters its junction against a red light (`obey_lights`) |
    | failure to yield | −1 (v3: −3) | the step the ego drives onto an occupied crosswalk it could have stopped for (`yield_to_pedestrians`) |
    | success | +1 | the step that ends the episode with `info["is_success"]` |

    So a successful episode returns 2 (plus the few centimetres driven past the goal over the
    route's length); a failed one at most the progress it made (under 1 for a timeout, about 0
    for an arrival after a red light, below 0 after a collision, or after a red light with
    `end_on_violation`): a return above 1.5 means success. A timeout costs the success bonus
    (the env does not see `TimeLimit`'s truncation). The failure terms' weight is
    `failure_penalty` (1 in v2, 3 in v3).

    ## Starting State
    Every car starts at rest on an entry lane, the lane uniform and the movement uniform over the
    other approaches (p(l_t | l_g) = 1/(K−1)); slots never overlap. Pedestrians start on their
    walks' first legs. The light cycle starts at t = 0. The layout's slots bound the cars:
    `num_cars` above the layout's capacity less the ego raises `ValueError` at construction
    (15 on the one-lane four-way, 31 on the two-lane one, 11 / 23 on the T-junction, 15 on the
    roundabout).

    ## Episode End
    `done_when="ego"` (default): terminated when the ego reaches its goal or is in a collision
    (with a car, a pedestrian, or leaving the road). `done_when="all"` (the sensitivity
    analysis' criterion): terminated when every car has arrived or on any collision (after the
    ego arrives, actions are ignored and rewards are 0). With `end_on_violation`, also
    terminated in the step the ego breaks a rule that fails `is_success` (a red light with
    `obey_lights`, a failure to yield with `yield_to_pedestrians`): the episode's outcome
    is decided there, and an RL agent is not paid for the progress it would make after failing
    (see Rewards). Truncated by `TimeLimit` (`FLUIDS-v0`: 400 steps =
    40 s; `FLUIDS-v1`: 600; the sensitivity ids: 600).

    ## Snapshots and labels
    `env.unwrapped.snapshot()` returns an `EnvSnapshot` (arrays and JSON, never a pickle);
    `restore(snapshot)` on another env built with the same kwargs (reset with any seed, or
    never reset) continues bit-identically, labels included. The supervisor has memory, as the source's
    does: the velocity planner runs every `planner_period` steps and holds its targets in
    between, and the PID controllers integrate their errors. So the label is a function of
    the world and the planner's phase (the world's step count) and held targets (and, at the
    control level, the controllers' integrators), and all of these are in the snapshot: after
    `restore`, `supervisor_action()` equals the label of the env that drove there. A
    supervisor built afresh on the same world would replan at once and may differ between
    replans.

    ## Info
    Field meanings are shared with the multi-agent env (see
    `fluids_bench.tasks.fluids.core.infos`):

    * `supervisor_action`: the supervisor's label for the ego at `action_level` in the new
      state.
    * `collisions`: every new collision of this step in the world, as dicts
      `{step, a, b, kind}` (the ego's have 0 in `a` or `b`; `b = -1` off the road), and
      who was at fault: `at_fault` (a list of agents), the `rule` that decided it
      (`offroad`, `red_light`, `rear_end`, `moving_into_stationary`,
      `car_yields_to_pedestrian`, `turn_yields`, `entered_occupied`, `shared`) and
      `cut_in` (a rear-end whose leader came in front inside the follower's stopping
      distance); see `fluids_bench.tasks.fluids.sim.fault`.
    * `is_success` (on the terminating step): the cars the episode is about reached their goals
      and none of them was ever in a collision: the ego with `done_when="ego"` (collisions
      between other agents do not count), every car with `done_when="all"`; with
      `obey_lights`, the ego also never entered its junction against a red light; with
      `yield_to_pedestrians`, it also never failed to yield (`ego_failed_to_yield`).
    * `ego_ran_red_light`: the ego entered its junction against a red light.
    * `ego_failed_to_yield`: the ego drove onto a crosswalk on its route with a pedestrian on
      it that it could have stopped for (the pedestrian was on it since a moment at which the
      ego was not yet committed to it); see `fluids_bench.tasks.fluids.sim.crosswalks`.
    * `ego_arrived`: the ego reached its goal. `route`: the ego's route's name. `lights`:
      every light's state.

    ## Arguments
    Every keyword argument but `render_mode` is a field of
    `fluids_bench.tasks.fluids.config.FluidsConfig`, described there and in `__init__`'s
    `Args:`; the env keeps the checked ones as `env.config` (and each as an attribute).
    Numbers may be Python or numpy scalars. A bad value raises `ValueError` naming the
    argument, the value and what is allowed; an unknown argument raises `TypeError` (also a
    `ValueError`) listing the allowed ones.

    ## Version History
    * v4: the benchmark id for imitation and RL alike (`FLUIDS-v4`,
      `FLUIDS-Sensitivity-v4`): v3's spaces and reward, the driving score in each episode's
      last info (`driving_score=True`, `time_limit=600`), the velocity planner at every
      step (`planner_period=1`) so that the ego's label is what a supervisor built afresh
      from the state gives, and (`FLUIDS-v4`) the learner acting at the trajectory level,
      where a random policy's driving score is a small fraction of the supervisor's. The
      older ids are legacy, unchanged bit for bit.
    * v3: v2 with the reward's failure terms weighted 3 (`failure_penalty=3.0`;
      `FLUIDS-v3`, `FLUIDS-Sensitivity-v3`): with PPO's default discount a policy that
      waits its turn is then clearly worth more than one that rushes, and PPO with its
      defaults reaches BC's success (the docs' RL page). The ids to train RL agents on.
    * v2: v1's scenes, supervisor and success criterion, made RL-ready:
      `action_scale="normalized"`, `reward_version=1`, `obs_scale="normalized"`
      (`FLUIDS-v2`, `FLUIDS-Sensitivity-v2`). Off-the-shelf PPO learns it where it fails
      on v1 (the docs' RL page has the ablation). v0 and v1 are unchanged, bit for bit.
    * v1: `defensive=True`, `lidar_version=1`, `obey_lights=True` and
      `yield_to_pedestrians=True` by default (`FLUIDS-v1`, `FLUIDS-Sensitivity-v1`);
      `FLUIDS-v1` also runs 8 pedestrians and 600 steps (60 s), the busier scene that
      separates a random policy from the supervisor; collisions carry fault labels (in every
      version).
    * v0: initial release.
    """

    # "human" needs pygame (the ``human`` extra): asking for it without pygame is a clear error
    # "success_on_termination": info["is_success"] is on the terminating step only (readers such
    # as the sweep's plots cannot find it by probing the first step)
    metadata = {
        "render_modes": ["rgb_array", "human"],
        "render_fps": 10,
        "success_on_termination": True,
    }

    @SINGLE_AGENT.document
    def __init__(self, *, render_mode: str | None = None, **options: Any) -> None:
        """Build the env from its options, the fields of `FluidsConfig` (`config`; each is
        also an attribute of the env).

        Args:
            render_mode: `None` (default), `"rgb_array"` (a global view: routes, light
                states, this step's collisions outlined in red, time and step) or `"human"`
                (that view in a pygame window; needs `pip install "fluids-bench[human]"`:
                without it, asking for it raises an ImportError that says so).
        """
        SINGLE_AGENT.check_names(options)
        if render_mode == "human":
            from fluids_bench.tasks.fluids.sim.render import require_pygame

            require_pygame()
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"FluidsEnv: field 'render_mode' is {render_mode!r}; "
                f"allowed: {self.metadata['render_modes']} or None"
            )
        self.config = SINGLE_AGENT.config(options)
        # every option also as an attribute, read by the step code (copies of the config's)
        vars(self).update(SINGLE_AGENT.attributes(self.config))
        self.report_score = self.config.driving_score
        scenario = build_scenario("FluidsEnv", self.config, multi_agent=False)
        self.scene = scenario.scene
        self.supervisor_config = scenario.supervisor
        self.render_mode = render_mode
        self._renderer = self._window = None
        self.world = World(self.scene, scenario.layout)
        self.observer = Observer(scenario.observation, self.world)
        self.observation_space = self.observer.space
        self.action_space = levels.action_space(
            self.action_level, self.world, self.supervisor_config.waypoints, self.action_scale
        )
        self.supervisor = DrivingSupervisor(self.world, self.supervisor_config)
        self.faults = FaultTracker(self.world)
        # the episode's bookkeeping, read through the properties below: the ego's route
        # progress at the last step and its route's length (m), and whether the episode ended;
        # arrays written in place, so that a vector env keeps every world's as its own rows
        self._progress = np.array([0.0, 1.0])
        self._done = np.zeros((), dtype=np.bool_)

    _last_s = Entry("_progress", 0, float)  # the ego's route progress at the last step (m)
    _route_length = Entry("_progress", 1, float)  # its route's length (m)
    _ended = Entry("_done", (), bool)  # the episode ended

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        seed = as_seed(seed)  # np.int64(5) seeds as 5
        super().reset(seed=seed)
        self.world = World(self.scene, self.world.layout)
        spawn(self.world, self.np_random)
        self.supervisor = DrivingSupervisor(self.world, self.supervisor_config)
        self.supervisor.prepare(self.world)
        self.faults = FaultTracker(self.world)
        self._ended = False
        self._last_s = float(self.world.route_s[0])
        self._route_length = float(rules.route_length(self.world.path_len[0], self._last_s))
        if self.render_mode == "human":
            self.render()
        return self._observe(), self._info([])

    def step(self, action):
        if self._ended:
            raise RuntimeError("FluidsEnv: step() called after the episode ended; call reset()")
        action = levels.validate(
            self.action_level, self.action_space, action, "FluidsEnv", self.world,
            self.action_scale,
        )  # fmt: skip
        return self._step_valid(action)

    def _step_valid(self, action):
        """`step` with `action` as `levels.validate` returns it (the vector env
        checks a whole batch at once, then clips each world's with `levels.clip`)."""
        events = self.world.step(self._act(action))
        judged = self._judge(events)
        if not self._ended:
            self.supervisor.prepare(self.world)
        reward, terminated, info = self._report(events, judged)
        return self._observe(), reward, terminated, False, info

    def _act(self, action):
        """The first part of `_step_valid`: every agent's controls (N, 2) with the ego's
        `action` at its level, the supervisor filling the levels below and its PID loops'
        memory advanced as if they were executed (`core.actions.act` on this world as one
        row, as the vector env does for its B worlds). Then the world steps under them (alone,
        or with others in a `WorldBatch`), `_judge` takes the new collisions, the supervisor
        plans and proposes its next controls unless the episode ended (alone, or in a
        `SupervisorBatch`), `_report` returns the step's reward, termination and info, and
        the world is observed (alone, or in one call for a batch)."""
        w = self.world
        # after the ego arrived ("all" mode) the others drive on and the action is ignored
        rows = _EGO if w.active[0] else _NO_ROW
        out = np.empty((1, w.n, 2))
        changed = decode.act(
            self.action_level, rows, rows, np.reshape(action, (1, -1))[: len(rows)], _GOING,
            decode.OneWorld(w), decode.Pilots.of_one(self.supervisor), out,
        )  # fmt: skip
        if len(changed):
            self._route_length = float(rules.route_length(w.path_len[0], self._last_s))
        return out[0]

    def _judge(self, events) -> Judged:
        """After the world stepped with `events`: faults and termination (`_ended`).
        Returns what `_report` needs (`fluids_bench.tasks.fluids.core.rules.Judged`, one
        row)."""
        broken = self._violations()
        self.faults.update()
        return self._judge_recorded(events, self._violations() - broken)

    def _judge_recorded(self, events, broken) -> Judged:
        """`_judge` once the fault tracker recorded the step (alone, or in a
        `FaultBatch`); `broken`: the rules the
        ego broke in it (`_violations` after the record less before). The rules'
        `judge_worlds` on this env's world as one row."""
        w = self.world
        judged, self._last_s = rules.judge_worlds(
            self, w.reached, w.is_car, rules.involved(events, 0),
            bool(events), broken, self._last_s, (w.s, w.offset, w.path_len),
        )  # fmt: skip
        self._ended = judged.terminated
        return judged

    def _report(self, events, judged: Judged) -> tuple[float, bool, dict]:
        """The step's reward, termination and info, once the supervisor proposed (a batch
        computes the reward and `is_success` of all its worlds at once with the same
        rules)."""
        w, terminated = self.world, self._ended
        info = self._info(events)
        success = False  # only read where the episode ends (the info, the success bonus)
        if terminated:
            faults = self.faults
            arrived, clean = rules.subjects(self, w.reached, w.collided, w.is_car)
            success = rules.succeeded(
                self, arrived, clean, bool(faults.ran_red[0]), bool(faults.failed_to_yield[0])
            )
            info["is_success"] = bool(success)
        info.update(self._episode_score(events, terminated))
        reward = rules.step_rewards(self, judged, success, self._route_length)
        if self.render_mode == "human":
            self.render()
        return float(reward), terminated, info

    def _episode_score(self, events, terminated: bool) -> dict[str, Any]:
        """With `driving_score`, the driving score's info entries
        (`episode_report`) when this step ends
        the episode: it `terminated`, or its world reached `time_limit` steps (a timeout);
        else nothing. Every face (the vector env too) calls this."""
        if not self.report_score:
            return {}
        timed_out = rules.timed_out(terminated, self.time_limit, self.world.steps)
        if not (terminated or timed_out):
            return {}
        return scoring.episode_report(
            self.world, self.faults, 0, self._route_length, events, timed_out
        )

    def render(self):
        """The current state seen from above (see `render_mode`): an RGB array (H, W, 3) in
        `"rgb_array"` mode; in `"human"` mode the frame goes to a window (returns None)."""
        if self.render_mode is None:
            gym.logger.warn(
                "FluidsEnv.render() called without a render_mode; pass "
                'render_mode="rgb_array" or "human" to gym.make'
            )
            return None
        from fluids_bench.tasks.fluids.sim.render import HumanWindow, Renderer

        if self._renderer is None or self._renderer.layout is not self.world.layout:
            self._renderer = Renderer(self.world.layout)
        frame = self._renderer.render(self.world)
        if self.render_mode == "rgb_array":
            return frame
        if self._window is None:
            self._window = HumanWindow("FLUIDS", self.metadata["render_fps"])
        self._window.show(frame)
        return None

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
        self._renderer = self._window = None

    # ------------------------------------------------------------------ supervisor protocol
    def supervisor_action(self):
        """The supervisor's action for the ego at `action_level` in the current state."""
        return labels.label(self.supervisor, self.world, self.action_level, 0, self.action_scale)

    # ------------------------------------------------------------------ snapshots
    # the world (agents, lights, time and step count), the supervisor's memory (the velocity
    # planner's held targets, the PID controllers' integrators, the proposed controls), the
    # fault tracker and the episode's bookkeeping; the compiled layout is built from the
    # kwargs alone and is taken from the restoring env
    _snapshot_fields = ("world", "supervisor", "faults", "_route_length", "_last_s", "_ended")

    def _snapshot_static(self) -> dict[str, Any]:
        return {"layout": self.world.layout}

    # ------------------------------------------------------------------ helpers
    def _observe(self) -> np.ndarray:
        return self.observer.observe(self.world, self.np_random)

    def _violations(self) -> int:
        """How many of the rules that fail `is_success` the ego has broken so far (a red
        light with `obey_lights`, yielding with `yield_to_pedestrians`)."""
        faults = self.faults
        return rules.violations(self, bool(faults.ran_red[0]), bool(faults.failed_to_yield[0]))

    def _info(self, events) -> dict[str, Any]:
        """The step's info (`fluids_bench.tasks.fluids.core.infos.ego_info` of this world)."""
        w, faults = self.world, self.faults
        return infos.ego_info(
            self.supervisor_action(), faults.annotate(events), w.reached, w.route, w,
            bool(faults.ran_red[0]), bool(faults.failed_to_yield[0]), w.light_state,
        )  # fmt: skip
