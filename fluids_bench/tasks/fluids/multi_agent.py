"""FLUIDS as a PettingZoo `ParallelEnv`: several controlled cars at once, everyone else supervised.

Build it with `parallel_env` (the PettingZoo convention), e.g.
`fluids_bench.tasks.fluids.multi_agent.parallel_env(controlled_cars=6, num_cars=2)`.
"""

from __future__ import annotations

import copy
import inspect
from collections.abc import Callable, Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import ParallelEnv

from fluids_bench.core.snapshot import SnapshotMixin
from fluids_bench.core.validation import as_seed
from fluids_bench.tasks.fluids import driving_score as scoring
from fluids_bench.tasks.fluids import levels
from fluids_bench.tasks.fluids.config import MULTI_AGENT
from fluids_bench.tasks.fluids.core import actions as decode
from fluids_bench.tasks.fluids.core import labels, rules
from fluids_bench.tasks.fluids.core.infos import agent_info
from fluids_bench.tasks.fluids.core.rules import Rules
from fluids_bench.tasks.fluids.observations import OBS_BOUND, Observer
from fluids_bench.tasks.fluids.scenario import (
    build_scenario,
)
from fluids_bench.tasks.fluids.sim.fault import FaultTracker
from fluids_bench.tasks.fluids.sim.spawn import spawn
from fluids_bench.tasks.fluids.sim.world import World
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor

WHERE = "FluidsParallelEnv"
STATE_PER_AGENT = 6  # x, y, cos θ, sin θ, v, active
STATE_PER_LIGHT = 3  # one-hot of go / caution / stop
_GOING = np.ones(1, np.bool_)  # `decode.act`'s one world, which steps

AgentObserver = Callable[[World, np.random.Generator, int], Any]


def agent_name(index: int) -> str:
    return f"car_{index}"


def _takes_ego(fn: Callable[..., Any]) -> bool:
    try:
        return "ego" in inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return False


class _PartObserves:
    """The family observes for any agent itself: `part.observe(world, rng, ego=agent)`."""

    def __init__(self, part: Any) -> None:
        self.part = part

    def __call__(self, world: World, rng: np.random.Generator, agent: int):
        return self.part.observe(world, rng, ego=agent)


class _SensorObserves:
    """The family's sensor takes `ego`: observe through it, clipped into the family's Box."""

    def __init__(self, sensor: Any, space: spaces.Box) -> None:
        self.sensor, self.space = sensor, space

    def __call__(self, world: World, rng: np.random.Generator, agent: int):
        out = np.clip(self.sensor.observe(world, rng, ego=agent), self.space.low, self.space.high)
        return out.astype(self.space.dtype, copy=False)


class _Scaled:
    """An agent observer followed by the family's `obs_scale="normalized"` map."""

    def __init__(self, observe: AgentObserver, scale: Callable[[np.ndarray], np.ndarray]) -> None:
        self.observe, self.scale = observe, scale

    def __call__(self, world: World, rng: np.random.Generator, agent: int):
        return self.scale(self.observe(world, rng, agent))


class _EgoOnly:
    """A family that can only observe for agent 0."""

    def __init__(self, part: Any) -> None:
        self.part = part

    def __call__(self, world: World, rng: np.random.Generator, agent: int):
        return self.part.observe(world, rng)


def agent_observers(observer: Observer) -> tuple[dict[str, AgentObserver], list[str]]:
    """For each family of `observer`, a picklable function `(world, rng, agent) ->
    observation` that observes from car `agent`'s point of view, and the families that cannot.

    Uses the family's `observe(world, rng, ego=...)` when it takes `ego`, otherwise its
    sensor's `observe(..., ego=...)` clipped into the family's Box. A family offering neither
    is listed second; its function observes for agent 0 whatever agent it is asked for."""
    out: dict[str, AgentObserver] = {}
    ego_only: list[str] = []
    for kind, part in observer.parts.items():
        sensor = getattr(part, "sensor", None)
        if _takes_ego(part.observe):
            out[kind] = _PartObserves(part)
        elif (
            sensor is not None and _takes_ego(sensor.observe) and isinstance(part.space, spaces.Box)
        ):
            # clipped into the physical Box, then scaled as the family does (obs_scale)
            raw = getattr(part, "raw_space", part.space)
            out[kind] = _SensorObserves(sensor, raw)
            if getattr(part, "scale", None) is not None:
                out[kind] = _Scaled(out[kind], part.scale)
        else:
            out[kind] = _EgoOnly(part)
            ego_only.append(kind)
    return out, ego_only


class FluidsParallelEnv(SnapshotMixin, ParallelEnv):
    """
    ## Description
    FLUIDS (ch. 7 of the source dissertation) with `controlled_cars` learner-controlled cars,
    the agents `car_0 … car_{n-1}`, acting simultaneously at one signalised intersection.
    `num_cars` background cars and `num_pedestrians` pedestrians are driven by the same
    four-level supervisor as in `FLUIDS-v0`, which also labels every state each agent visits
    at the level the agents act at (`infos[agent]["supervisor_action"]`,
    `supervisor_action`). The supervisor plans for all agents jointly, controlled or not.

    ## Action Space
    Per agent, as `FLUIDS-v0`'s `action_level`: `"behavior"` `Discrete(n)` (movement
    from the car's entry lane), `"trajectory"` `Box(-50, 50, (2K,))` (next `K` path points
    in the car's frame, m), `"velocity"` `Box(0, v_max, (1,))` (target speed, m/s) or
    `"control"` `Box(-1, 1, (2,))` (normalised [steering, force]); with
    `action_scale="normalized"` (`FLUIDS-MultiAgent-v2`) every Box level is `[-1, 1]`,
    labels included, as `FLUIDS-v2`'s. The supervisor fills the
    levels below for each car. A live agent missing from the action dict follows its
    supervisor this step; actions for agents that already left are ignored. `actions` must
    be a dict (`None` or a list raise `ValueError`); unknown names raise `ValueError`
    listing the agents; a malformed action (wrong shape, not finite, strings, bools, complex
    numbers) raises `ValueError` naming the agent, the level and the allowed form. Box
    actions are clipped to bounds.

    ## Observation Space
    Per agent, the `FLUIDS-v0` observation (`obs_type` and the same sensor options) taken
    from that car's point of view (`obs_scale="normalized"`: `FLUIDS-v2`'s flat vectors in
    [-1, 1]). A family whose sensor cannot observe for another car than
    agent 0 raises `NotImplementedError` at construction when `controlled_cars > 1`.

    ## State
    `state` is a global view for centralised training: `Box(float32)` of
    `6 * N + 3 * L` values, for each of the `N` agents of the world (controlled cars,
    background cars, pedestrians, in that order) `[x, y, cos θ, sin θ, v, active]` (m, m/s;
    positions clipped to ±1000 m), then for each of the `L` lights a one-hot of go / caution /
    stop. The space is `state_space`.

    ## Rewards
    Per agent, as `FLUIDS-v0` (`fluids_bench.tasks.fluids.core.rules.step_rewards`): the
    metres of route gained this step divided by the route's length from the start, minus 1 in a
    step where that car is in a collision. `reward_version=1` (`FLUIDS-MultiAgent-v2`): also
    +1 on the step the car arrives without a collision (its `is_success`), so a successful
    agent returns 2 and a failed one less than 1 (see `FLUIDS-v2`'s Rewards).

    ## Starting State
    Every car starts at rest in its own entry-lane slot (slots never overlap), the lane uniform
    and the movement uniform over the other approaches; pedestrians start on their walks. The
    layout's slots bound the cars: `controlled_cars + num_cars` above the layout's capacity
    raises `ValueError` at construction naming the maximum (16 cars on the one-lane four-way,
    32 on the two-lane one, 12 / 24 on the T-junction, 16 on the roundabout).

    ## Episode End
    An agent terminates when it reaches its goal or is in a collision (with any car, a
    pedestrian, or leaving the road). With `black_death=True` a finished agent instead stays
    in `agents`, neither terminated nor truncated, with an all-zero observation (after its
    last real one), reward 0 and its actions ignored, until every agent has finished or
    `max_cycles` is reached; then all end in the same step (terminated if it finished,
    truncated otherwise). That keeps the agent set fixed, as SuperSuit's
    `pettingzoo_env_to_vec_env_v1` needs (see the README's multi-agent recipe). A car in a collision leaves the road: it is removed from
    the world, so the others neither see it nor collide with its wreck. The episode goes on for
    the remaining agents. All live agents are truncated after `max_cycles` steps. The episode
    is over when `agents` is empty.

    ## Info
    Per agent; field meanings are shared with `FLUIDS-v0` (see
    `fluids_bench.tasks.fluids.core.infos`):

    * `supervisor_action`: its label at `action_level` in the new state.
    * `collisions`: this step's new collisions the agent is part of, as dicts
      `{step, a, b, kind}` (`b = -1` off the road), with who was at fault (`at_fault`,
      `rule`, `cut_in`: see `fluids_bench.tasks.fluids.sim.fault`).
    * `is_success` (in a terminated or truncated agent's last info): the car reached its goal
      and was never in a collision (collisions between other agents do not count), as
      `FLUIDS-v0`'s with `done_when="ego"`.
    * `arrived`: the car reached its goal. `route`: its route's name.

    ## Snapshots and labels
    `env.snapshot()` returns a picklable state (the world, the supervisor's memory, the live
    and dead agents, the cycle count, `np_random`); `env.restore(snapshot)` on another env
    built with the same kwargs (reset with any seed) continues bit-identically, labels
    included. As in `FLUIDS-v0`, the label is a function of the world and the velocity
    planner's phase and held targets (and the PID controllers' integrators), all in the
    snapshot.

    ## Arguments
    Every keyword argument but `render_mode` is a field of
    `fluids_bench.tasks.fluids.config.FluidsConfig` (`FLUIDS-v0`'s options less
    `pedestrian_speed`, `light_cycle_scale`, `done_when`, `obey_lights`,
    `end_on_violation` and `time_limit`, plus `controlled_cars`, `max_cycles` and
    `black_death`), described there and in `__init__`'s `Args:`; the env keeps the checked
    ones as `env.config` (and each as an attribute). Errors as `FLUIDS-v0`'s.

    ## Version History
    * v4: v3 with the driving score, the velocity planner at every step (Markov labels) and
      the agents acting at the trajectory level, as `FLUIDS-v4`.
    * v3: v2 with the collision term weighted 3 (`failure_penalty=3.0`), as `FLUIDS-v3`.
    * v2: v1 made RL-ready: normalised actions and labels, a reward that pays success, flat
      observations in [-1, 1] (`action_scale`, `reward_version`, `obs_scale`).
    * v1: defensive, pedestrian-yielding background drivers by default; fault labels in
      `collisions`.
    * v0: initial release.
    """

    metadata = {
        "name": "fluids_multi_v0",
        "render_modes": ["rgb_array"],
        "render_fps": 10,
        "is_parallelizable": True,
    }

    # the world, the supervisor's memory, the agents' bookkeeping and PettingZoo's seed
    _snapshot_fields = (
        "world",
        "supervisor",
        "faults",
        "agents",
        "_dead",
        "_just_died",
        "_cycles",
        "_last_s",
        "_route_length",
        "np_random_seed",
    )

    def _snapshot_static(self) -> dict[str, Any]:
        return {"layout": self.world.layout}

    @MULTI_AGENT.document
    def __init__(self, *, render_mode: str | None = None, **options: Any) -> None:
        """Build the env from its options, the fields of `FluidsConfig` that it takes
        (`config`; each is also an attribute of the env).

        Args:
            render_mode: `None` (default) or `"rgb_array"` (`FLUIDS-v0`'s global view,
                the first live agent highlighted).
        """
        MULTI_AGENT.check_names(options)
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(
                f"{WHERE}: field 'render_mode' is {render_mode!r}; allowed: "
                f"{self.metadata['render_modes']} or None"
            )
        self.config = MULTI_AGENT.config(options)
        # every option also as an attribute, read by the step code (copies of the config's;
        # PettingZoo's tests set max_cycles)
        vars(self).update(MULTI_AGENT.attributes(self.config))
        self.report_score = self.config.driving_score
        controlled_cars = self.config.controlled_cars
        scenario = build_scenario(WHERE, self.config, multi_agent=True)
        self.scene = scenario.scene
        self.supervisor_config = scenario.supervisor
        self.render_mode = render_mode
        self._renderer = None
        self.world = World(self.scene, scenario.layout)
        self.supervisor = DrivingSupervisor(self.world, self.supervisor_config)
        self.faults = FaultTracker(self.world)
        self._dead: set[int] = set()  # black death: finished agents kept in the episode
        self._just_died: set[int] = set()
        self.observer = Observer(scenario.observation, self.world)
        self._observers, ego_only = agent_observers(self.observer)
        if controlled_cars > 1 and ego_only:
            raise NotImplementedError(
                f"{WHERE}: obs_type {ego_only} observes only for agent 0 (the sensor's observe() "
                "takes no 'ego' argument); use controlled_cars=1 or another obs_type"
            )

        self.possible_agents = [agent_name(i) for i in range(controlled_cars)]
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        self.agents: list[str] = []
        self._action_space = self._build_action_space()
        # one space object per agent, so seeding one agent's space leaves the others' alone
        self._action_spaces = {a: copy.deepcopy(self._action_space) for a in self.possible_agents}
        self._observation_spaces = {
            a: copy.deepcopy(self.observer.space) for a in self.possible_agents
        }
        self.state_space = self._build_state_space()
        self._np_random: np.random.Generator | None = None
        self.np_random_seed: int | None = None
        self._cycles = 0
        self._last_s = np.zeros(controlled_cars)
        self._route_length = np.ones(controlled_cars)

    # ------------------------------------------------------------------ spaces
    def observation_space(self, agent: str) -> spaces.Space:
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space:
        return self._action_spaces[agent]

    def _build_action_space(self) -> spaces.Space:
        return levels.action_space(
            self.action_level, self.world, self.supervisor_config.waypoints, self.action_scale
        )

    def _build_state_space(self) -> spaces.Box:
        n, lights = self.world.n, len(self.world.lights)
        low = np.tile(np.array([-OBS_BOUND, -OBS_BOUND, -1.0, -1.0, 0.0, 0.0], np.float32), n)
        high = np.tile(np.array([OBS_BOUND, OBS_BOUND, 1.0, 1.0, 0.0, 1.0], np.float32), n)
        high.reshape(n, STATE_PER_AGENT)[:, 4] = self.world.max_speed
        low = np.concatenate([low, np.zeros(STATE_PER_LIGHT * lights, np.float32)])
        high = np.concatenate([high, np.ones(STATE_PER_LIGHT * lights, np.float32)])
        return spaces.Box(low, high, dtype=np.float32)

    @property
    def np_random(self) -> np.random.Generator:
        if self._np_random is None:
            self._np_random, self.np_random_seed = seeding.np_random()
        return self._np_random

    # ------------------------------------------------------------------ PettingZoo API
    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None):
        seed = as_seed(seed)  # np.int64(5) seeds as 5
        if seed is not None:
            self._np_random, self.np_random_seed = seeding.np_random(seed)
        rng = self.np_random
        self.world = World(self.scene, self.world.layout)
        spawn(self.world, rng)
        self.supervisor = DrivingSupervisor(self.world, self.supervisor_config)
        self.supervisor.prepare(self.world)
        self.faults = FaultTracker(self.world)
        self._dead, self._just_died = set(), set()
        self.agents = list(self.possible_agents)
        self._cycles = 0
        n = len(self.possible_agents)
        self._last_s = self.world.route_s[:n].astype(np.float64)
        self._route_length = rules.route_length(self.world.path_len[:n], self._last_s)
        observations = {a: self._observe(i) for i, a in enumerate(self.agents)}
        infos = {a: self._info(i, []) for i, a in enumerate(self.agents)}
        return observations, infos

    def step(self, actions: dict[str, Any]):
        if not self.agents:
            raise RuntimeError(f"{WHERE}: step() called with no live agents; call reset()")
        if not isinstance(actions, Mapping):
            raise ValueError(
                f"{WHERE}: actions is {type(actions).__name__} {actions!r:.60}; allowed: a dict "
                f"from agent name to action (live agents: {self.agents})"
            )
        unknown = sorted(set(actions) - set(self.possible_agents), key=str)
        if unknown:
            raise ValueError(
                f"{WHERE}: actions for unknown agents {unknown}; allowed: {self.possible_agents}"
            )
        everyone = [self._index[a] for a in self.agents]
        live = [i for i in everyone if i not in self._dead]  # black death: the dead are no-ops
        chosen = {
            i: self._validate(actions[agent_name(i)], agent_name(i))
            for i in live
            if agent_name(i) in actions
        }
        w, sup = self.world, self.supervisor
        events = w.step(self._controls(chosen))
        self.faults.update()
        self._cycles += 1

        hit = {i: rules.agent_events(events, i) for i in live}
        reward, ended, success = self._judge(live, hit)
        rewards, terminations, truncations = {}, {}, {}
        for k, i in enumerate(live):
            a = agent_name(i)
            rewards[a] = reward[k]  # a numpy float64, as it always was
            terminations[a] = bool(ended[k])
            truncations[a] = not terminations[a] and self._cycles >= self.max_cycles
            if hit[i]:
                w.active[i] = False  # the car leaves the road with its episode
        finished = [i for i in live if terminations[agent_name(i)] or truncations[agent_name(i)]]
        timed_out = {i: truncations[agent_name(i)] for i in finished}  # (before black death)
        if self.black_death:
            self._black_death(everyone, live, rewards, terminations, truncations)
        else:
            self.agents = [a for a in self.agents if not (terminations[a] or truncations[a])]
        if len(self._dead) < len(self.agents):
            sup.prepare(w)
        observations = {agent_name(i): self._observe(i) for i in everyone}
        infos = {agent_name(i): self._info(i, hit.get(i, [])) for i in everyone}
        for i in finished:
            infos[agent_name(i)]["is_success"] = bool(success[live.index(i)])
            if self.report_score:  # its episode ends: the driving score (timeout: max_cycles)
                infos[agent_name(i)].update(
                    scoring.episode_report(
                        w, self.faults, i, self._route_length[i], hit[i], timed_out[i]
                    )
                )
        return observations, rewards, terminations, truncations, infos

    def _judge(self, live: list[int], hit: dict[int, list]):
        """The rules (`fluids_bench.tasks.fluids.core.rules`) with one row per live agent,
        each its own subject (as `done_when="ego"`, no rule but collisions fails it): each
        one's reward, termination and `is_success`, (A,) each; updates `_last_s`."""
        w, rows = self.world, np.array(live, dtype=np.int64)
        rule = Rules(reward_version=self.reward_version, failure_penalty=self.failure_penalty)
        reached = w.reached[rows]
        s_now = rules.route_progress(reached, w.path_len[rows], w.s[rows], w.offset[rows])
        ego_hit = np.array([bool(hit[i]) for i in live], dtype=np.bool_)
        judged = rules.judge(
            rule, reached, ego_hit, ego_hit, s_now, self._last_s[rows], np.zeros(len(live), int)
        )
        self._last_s[rows] = s_now
        success = rules.succeeded(rule, reached, ~w.collided[rows])
        reward = rules.step_rewards(rule, judged, success, self._route_length[rows])
        return reward, judged.terminated, success

    def _black_death(self, everyone, live, rewards, terminations, truncations) -> None:
        """Keep finished agents in the episode (zero observation, reward 0, action ignored,
        neither terminated nor truncated) until every agent has finished or `max_cycles`
        is reached; then end the episode for all of them at once."""
        self._just_died = {
            i for i in live if terminations[agent_name(i)] or truncations[agent_name(i)]
        }
        self._dead |= self._just_died
        over = len(self._dead) == len(everyone) or self._cycles >= self.max_cycles
        for i in everyone:
            a = agent_name(i)
            if i in live:
                done = terminations[a]
            else:
                rewards[a] = 0.0
                done = True
            terminations[a] = over and (done or bool(self.world.reached[i]))
            truncations[a] = over and not terminations[a]
        if over:
            self.agents = []

    def state(self) -> np.ndarray:
        w = self.world
        per_agent = np.column_stack(
            [
                w.state[:, 0],
                w.state[:, 1],
                np.cos(w.state[:, 2]),
                np.sin(w.state[:, 2]),
                w.state[:, 3],
                w.active,
            ]
        )
        lights = np.eye(STATE_PER_LIGHT)[np.asarray(w.light_state, dtype=np.int64)]
        flat = np.concatenate([per_agent.ravel(), lights.ravel()]).astype(np.float32)
        return np.clip(flat, self.state_space.low, self.state_space.high)

    def render(self) -> np.ndarray | None:
        """`"rgb_array"`: the global view (H, W, 3) uint8, the first live agent highlighted."""
        if self.render_mode is None:
            gym.logger.warn(
                f'{WHERE}.render() called without a render_mode; pass render_mode="rgb_array"'
            )
            return None
        from fluids_bench.tasks.fluids.sim.render import Renderer

        if self._renderer is None or self._renderer.layout is not self.world.layout:
            self._renderer = Renderer(self.world.layout)
        highlight = self._index[self.agents[0]] if self.agents else 0
        return self._renderer.render(self.world, ego=highlight)

    def close(self) -> None:
        self._renderer = None

    # ------------------------------------------------------------------ supervisor protocol
    def supervisor_action(self, agent: str):
        """The supervisor's action for `agent` at `action_level` in the current state."""
        return self._label(self._index[agent])

    def _label(self, i: int):
        return labels.label(self.supervisor, self.world, self.action_level, i, self.action_scale)

    # ------------------------------------------------------------------ helpers
    def _controls(self, chosen: dict[int, Any]) -> np.ndarray:
        """Every agent's controls (N, 2) with the chosen agents' actions at `action_level`,
        the rest supervised (`decode.act`, one row per chosen agent); the PID memory is
        committed for them."""
        w = self.world
        agents = np.fromiter(chosen, np.int64, len(chosen))
        values = np.array([np.reshape(v, -1) for v in chosen.values()])
        out = np.empty((1, w.n, 2))
        changed = decode.act(
            self.action_level, np.zeros_like(agents), agents, values, _GOING,
            decode.OneWorld(w), decode.Pilots.of_one(self.supervisor), out,
        )  # fmt: skip
        for i in agents[changed].tolist():
            self._route_length[i] = rules.route_length(w.path_len[i], self._last_s[i])
        return out[0]

    def _validate(self, action, agent: str):
        return levels.validate(
            self.action_level,
            self._action_space,
            action,
            f"{WHERE} {agent}",
            self.world,
            self.action_scale,
        )

    def _observe(self, i: int):
        if i in self._dead and i not in self._just_died:  # its last real observation, then 0
            return _zeros(self._observation_spaces[agent_name(i)])
        rng, w = self.np_random, self.world
        if self.observer.single:
            return next(iter(self._observers.values()))(w, rng, i)
        return {kind: fn(w, rng, i) for kind, fn in self._observers.items()}

    def _info(self, i: int, events) -> dict[str, Any]:
        return agent_info(self._label(i), self.faults.annotate(events), self.world, i)


def _zeros(space: spaces.Space):
    """An all-zero observation of `space` (clipped into a Box's bounds)."""
    if isinstance(space, spaces.Dict):
        return {k: _zeros(sub) for k, sub in space.spaces.items()}
    return np.clip(np.zeros(space.shape, space.dtype), space.low, space.high).astype(space.dtype)


def parallel_env(**kwargs: Any) -> FluidsParallelEnv:
    """Build the multi-agent FLUIDS env (see `FluidsParallelEnv` for the arguments)."""
    return FluidsParallelEnv(**kwargs)
