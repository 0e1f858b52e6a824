"""FLUIDS as a Gymnasium `VectorEnv`: `gym.make_vec(id, B, vectorization_mode="vector_entry_point")`."""

from __future__ import annotations

from enum import Enum
from typing import Any

import numpy as np
from gymnasium.spaces import Box
from gymnasium.vector import VectorEnv

try:
    from gymnasium.vector import AutoresetMode
except ImportError:  # Gymnasium 1.0 (added in 1.1): the same enum, whose default 1.0 implies

    class AutoresetMode(Enum):
        """Gymnasium 1.1's `gymnasium.vector.AutoresetMode`, for Gymnasium 1.0."""

        NEXT_STEP = "NextStep"
        SAME_STEP = "SameStep"
        DISABLED = "Disabled"


from gymnasium.vector.utils import batch_space, create_empty_array

from fluids_bench.core.snapshot import WrappedSnapshot
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.core.validation import as_seed, check_int, fail, is_int, unknown_arguments
from fluids_bench.tasks.fluids import levels
from fluids_bench.tasks.fluids.config import SINGLE_AGENT
from fluids_bench.tasks.fluids.core import actions as decode
from fluids_bench.tasks.fluids.core import rules
from fluids_bench.tasks.fluids.core.labels import label_rows
from fluids_bench.tasks.fluids.env import FluidsEnv
from fluids_bench.tasks.fluids.sim.batch import FaultBatch, Rows, WorldBatch
from fluids_bench.tasks.fluids.supervisor.batch import SupervisorBatch
from fluids_bench.tasks.fluids.vector.actions import check_batch
from fluids_bench.tasks.fluids.vector.bounds import check_num_envs
from fluids_bench.tasks.fluids.vector.infos import batch_infos, step_infos

WHERE = "FluidsVectorEnv"
# the vector env's own arguments; every other one is an option (FluidsConfig) of each world's
# FluidsEnv
OWN_ARGUMENTS = ("num_envs", "max_episode_steps", "autoreset_mode", "render_mode")
# the vector entry point's, for worker processes (vector/workers.py)
WORKER_ARGUMENTS = ("num_workers", "context", "worker_timeout")
# FluidsEnv's episode bookkeeping arrays (core/rules.py's judge_worlds writes them)
EPISODE = ("_progress", "_done")
# the wrappers gym.make puts around a FluidsEnv, outermost first (a world's snapshot names them
# so that core.snapshot.restore can put it into a gym.make env, and back)
MAKE_WRAPPERS = ("TimeLimit", "OrderEnforcing", "PassiveEnvChecker")


def world_seeds(seed: Any, n: int) -> list[int | None]:
    """Each of `n` worlds' reset seed: None, `seed + i` for an integer, or a list's i-th."""
    seed = as_seed(seed)
    if seed is None:
        return [None] * n
    if isinstance(seed, int) and not isinstance(seed, bool):
        return [seed + i for i in range(n)]
    if isinstance(seed, list | tuple) and len(seed) == n:
        return [as_seed(s) for s in seed]
    fail(WHERE, "seed", seed, f"None, an integer (world i gets seed + i) or a list of {n} seeds")


def world_index(index: Any, n: int) -> int:
    """A world's index among `n`, as an int."""
    if not is_int(index) or not 0 <= index < n:
        fail(WHERE, "index", index, f"an integer in [0, {n - 1}]")
    return int(index)


def check_reset_mask(mask: Any, n: int) -> np.ndarray:
    """`options["reset_mask"]`: a bool array over the `n` worlds, some set."""
    if (
        not isinstance(mask, np.ndarray)
        or mask.dtype != np.bool_
        or mask.shape != (n,)
        or not mask.any()
    ):
        fail(
            WHERE,
            'options["reset_mask"]',
            mask,
            f"a numpy bool array of shape ({n},) with at least one True",
        )
    return mask


def attribute_values(values: Any, n: int) -> list | tuple:
    """`set_attr`'s values: one per world from a list or tuple of `n`, else `values` for
    all (as `SyncVectorEnv.set_attr`)."""
    if not isinstance(values, list | tuple):
        values = [values] * n
    if len(values) != n:
        fail(WHERE, "values", values, f"one value, or a list of {n} values")
    return values


class FluidsVectorEnv(VectorEnv):
    """B independent FLUIDS worlds behind one Gymnasium 1.x `VectorEnv`.

    Build it with `gym.make_vec("FLUIDS-v1", num_envs=B, vectorization_mode="vector_entry_point",
    **kwargs)` (every single-agent FLUIDS id registers it); `kwargs` are the scalar env's
    options (`FluidsConfig`), checked with its errors; `config` is every world's.

    **What it returns.** Batched spaces (`single_action_space` and `single_observation_space`
    are the scalar env's); observations `(B, ...)`, rewards, `terminated` and `truncated`
    `(B,)`; infos as Gymnasium's dict of batched arrays with `_key` masks:
    `info["supervisor_action"]` is `(B, ...)` (`(B,)` integers at the behaviour level),
    `is_success` is present (mask) in the worlds whose episode ended this step, `collisions`
    holds each world's list of this step's collisions with their fault labels.

    **Equal to the scalar env.** World `i` after `reset(seed=s)` is the scalar env (`gym.make`
    of the same id and kwargs) reset with seed `s + i` (a list of seeds gives one per world, as
    `SyncVectorEnv`), and under the same actions it returns the same observations, rewards,
    flags, labels and infos bit for bit; the whole batch equals `SyncVectorEnv` over the id.
    `max_episode_steps` (the id's step limit, passed by `make_vec`) truncates each world as
    `TimeLimit` does. `autoreset_mode`: `"NextStep"` (default, as `metadata` states),
    `"SameStep"` (`final_obs`/`final_info` in the info) or `"Disabled"` (reset ended
    worlds with `reset(options={"reset_mask": mask})`).

    **How it steps.** Each world is a scalar `FluidsEnv` (no wrapper stack; all share one
    compiled layout) whose state is rows of batched arrays: every array of its world, fault
    tracker and supervisor, its clock and light lookup, its episode bookkeeping (each object's
    attribute is a view of its row). Its step is split in parts, each run for all worlds
    before the next:

    1. the controls of every world, at every action level (array operations and, at the
       velocity and trajectory levels, one compiled call: `core.actions.act`, every face's);
    2. the clocks advance (one lookup in the clock's ticks), the lights are looked up again
       where a light changed (one call for all those worlds), and one compiled call moves
       every world
       (`WorldBatch`);
    3. one records every world's step for fault labels
       (`FaultBatch`);
    4. the steps are judged for all worlds at once (termination, the rewards' terms:
       `fluids_bench.tasks.fluids.core.rules.judge_worlds`, which `FluidsEnv` calls with
       one row);
    5. the supervisors plan (one call finds every world's cars off their routes, recovery
       runs world by world where any is; two calls plan the velocities of every world due for
       a plan) and one call proposes every supervisor's next controls
       (`SupervisorBatch`);
    6. the rewards and `is_success` of all worlds (`rules.succeeded` and
       `rules.step_rewards`, the scalar env's rules on B rows); with
       `driving_score` (the v4 ids), each world whose episode ends here gets the driving
       score's entries from its env's `_episode_score` (the one rule, in
       `fluids_bench.tasks.fluids.driving_score`);
    7. one observes every world (a noiseless explicit or quasi-LIDAR observation; others
       world by world);
    8. the infos and labels are read from the batched rows for all worlds at once
       (`step_infos`; with `"SameStep"`
       autoresets, world by world).

    Only rare events run world by world: collisions (the exact check and fault labels), a
    route changing, recovery planning and resets (the worlds whose lights change are looked up
    in one call, `fluids_bench.tasks.fluids.sim.lights.look_up`). The parts are the scalar
    env's own, so equality holds by construction. A batch of one
    world steps with the scalar env's `step` itself (the phases' fixed costs would exceed it). The vector layer
    checks the whole action batch before any world moves, writes observations into
    preallocated batched arrays and builds the batched infos key by key for all worlds at once.

    **Snapshots.** `snapshot(i)` returns world `i`'s state as
    `fluids_bench.core.snapshot.snapshot` returns it for a `gym.make` env (its step
    count included, as `TimeLimit`'s); `restore(i, snap)` puts such a snapshot, from this
    env or from a scalar env of the same id and kwargs, into world `i`.

    `render_mode="rgb_array"`: `render()` returns one frame per world. `call`, `get_attr`
    and `set_attr` reach each world's `FluidsEnv` as `SyncVectorEnv`'s reach its envs.
    `num_envs` is an integer ≥ 1 and at most what the memory available now holds
    (`fluids_bench.tasks.fluids.vector.bounds`); a bad value raises `ValueError` naming
    it.
    """

    metadata = {
        "render_modes": ["rgb_array"],
        "render_fps": FluidsEnv.metadata["render_fps"],
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int | None = None,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        self.num_envs = check_int(WHERE, "num_envs", num_envs, 1)
        check_num_envs(WHERE, self.num_envs)  # before building any world
        if max_episode_steps is not None:
            max_episode_steps = check_int(WHERE, "max_episode_steps", max_episode_steps, 1)
        self.max_episode_steps = max_episode_steps
        modes = [m.value for m in AutoresetMode]
        try:
            self.autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError:
            fail(WHERE, "autoreset_mode", autoreset_mode, f"one of {modes} or an AutoresetMode")
        if render_mode not in (None, *self.metadata["render_modes"]):
            fail(
                WHERE,
                "render_mode",
                render_mode,
                f"None or {self.metadata['render_modes']} (to watch one world in a window, "
                'use gym.make(..., render_mode="human"))',
            )
        options = SINGLE_AGENT.options  # every world's FluidsConfig
        unknown = sorted(set(kwargs) - set(options))
        if unknown:
            raise unknown_arguments(WHERE, unknown, [*options, *OWN_ARGUMENTS, *WORKER_ARGUMENTS])
        self.render_mode = render_mode
        self.metadata = {**self.metadata, "autoreset_mode": self.autoreset_mode}
        # the first world checks the kwargs (the scalar env's errors); the compiled layout is
        # cached per spec, so every world shares the first one's
        self.envs = [FluidsEnv(render_mode=render_mode, **kwargs) for _ in range(self.num_envs)]
        self.config = self.envs[0].config  # every world's (FluidsConfig)
        self.single_action_space = self.envs[0].action_space
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        space = self.single_action_space
        self._bounds = (  # flat lists, as levels.validate clips with them
            (space.low.reshape(-1).tolist(), space.high.reshape(-1).tolist())
            if isinstance(space, Box)
            else None
        )
        self._worlds = WorldBatch([env.world for env in self.envs])
        self._faults = FaultBatch([env.faults for env in self.envs])
        self._supervisors = SupervisorBatch([env.supervisor for env in self.envs])
        # the envs' episode bookkeeping (their arrays stay theirs through resets and restores)
        self._episodes = Rows(self.envs, EPISODE)
        self._bound_arrays = (
            tuple(np.asarray(b, dtype=np.float64) for b in self._bounds) if self._bounds else None
        )
        behavior = self.envs[0].action_level == "behavior"  # Discrete: integer labels
        self._labels = np.zeros(
            (self.num_envs, *self.envs[0].action_space.shape),
            np.int64 if behavior else np.float32,
        )
        self.single_observation_space = self.envs[0].observation_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._obs = create_empty_array(self.single_observation_space, self.num_envs, np.zeros)
        self._dict_obs = isinstance(self._obs, dict)
        self._batchable = self.envs[0].observer.batchable  # one call observes all
        # steps in each world's episode (TimeLimit's count)
        self._elapsed = np.zeros(self.num_envs, dtype=np.int64)
        self._ended = np.zeros(self.num_envs, dtype=np.bool_)  # episode ended: autoreset next
        # worlds whose env may hold new world, tracker or supervisor objects since the last
        # step (a reset, a restore, a call): bound to the batches before the next step
        self._stale = np.zeros(self.num_envs, dtype=np.bool_)
        self._has_reset = False

    # ------------------------------------------------------------------ Gymnasium API
    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset every world (or those of `options["reset_mask"]`); see the class docstring
        for seeds."""
        seeds = world_seeds(seed, self.num_envs)
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        mask = (
            np.ones(self.num_envs, np.bool_)
            if mask is None
            else check_reset_mask(mask, self.num_envs)
        )
        infos: list[dict | None] = [None] * self.num_envs
        for i in mask.nonzero()[0].tolist():
            obs, infos[i] = self.envs[i].reset(seed=seeds[i], options=options or None)
            self._write(i, obs)
            self._elapsed[i], self._ended[i] = 0, False
        self._stale |= mask
        self._has_reset = True
        return self._observations(), batch_infos(infos, self.num_envs)

    def step(self, actions):
        if not self._has_reset:
            raise RuntimeError(f"{WHERE}: step() called before reset()")
        actions = check_batch(WHERE, self.single_action_space, self.num_envs, actions)
        n, limit, mode = self.num_envs, self.max_episode_steps, self.autoreset_mode
        if mode is AutoresetMode.DISABLED and self._ended.any():
            raise RuntimeError(
                f"{WHERE}: world {int(self._ended.argmax())} ended; with autoreset_mode="
                f"{mode.value!r} reset it with reset(options={{'reset_mask': mask}}) first"
            )
        if n == 1:  # one world: the batched phases' fixed costs would exceed its step
            return self._step_alone(actions)
        worlds, faults, supervisors = self._bound_batches()
        stepping = ~self._ended  # the others autoreset this step
        index = stepping.nonzero()[0].tolist()
        self._act_all(actions, stepping, worlds, supervisors)
        events = worlds.step(stepping)
        rule, first = self.config, self.envs[0]  # FluidsConfig has the rules' fields
        ran_red, failed_to_yield = faults["ran_red"][:, 0], faults["failed_to_yield"][:, 0]
        before = rules.violations(rule, ran_red, failed_to_yield)
        faults.update(stepping, worlds)
        broken = rules.violations(rule, ran_red, failed_to_yield) - before  # in this step
        episodes, hit = self._episodes, worlds.hit
        last_s = episodes["_progress"][:, 0]
        judged, s_now = rules.judge_worlds(
            rule, worlds["reached"], first.world.is_car,
            rules.ego_hits(events, hit), hit, broken, last_s,
            (worlds["s"], worlds["offset"], worlds["path_len"]),
        )  # fmt: skip
        last_s[stepping] = s_now[stepping]
        episodes["_done"][stepping] = judged.terminated[stepping]
        going = stepping & ~judged.terminated  # stepped, and the episode goes on
        supervisors.plan(going, worlds, worlds.lights)
        supervisors.propose(going, worlds)
        arrived, clean = rules.subjects(
            rule, worlds["reached"], worlds["collided"], first.world.is_car
        )
        success = rules.succeeded(rule, arrived, clean, ran_red, failed_to_yield)
        reward = rules.step_rewards(rule, judged, success, episodes["_progress"][:, 1])
        rewards = np.where(stepping, reward, 0.0)
        terminated = stepping & judged.terminated
        self._elapsed += stepping
        # TimeLimit: truncated once the episode has taken max_episode_steps steps
        truncated = stepping & (self._elapsed >= (limit if limit is not None else np.inf))
        infos: dict[int, dict] = {}  # the worlds' own keys
        for i in terminated.nonzero()[0].tolist():
            infos[i] = {"is_success": bool(success[i])}
        if self.config.driving_score:  # the driving score of the episodes that end here
            due = terminated | truncated | (self._elapsed == self.config.time_limit)
            self._episode_scores(stepping & due, terminated, events, infos)
        batched_infos = mode is not AutoresetMode.SAME_STEP  # (final_info: world by world)
        if not batched_infos:  # each world's whole info, as FluidsEnv._report gives it
            for i in index:
                infos[i] = {**self.envs[i]._info(events[i]), **infos.get(i, {})}
        self._observe(stepping, index, worlds, worlds.lights)
        self._autoreset(stepping, terminated, truncated, infos)
        if batched_infos:  # the labels of the worlds whose supervisor just proposed
            self._labels[going] = label_rows(
                first.action_level, first.action_scale, (going, 0), worlds, supervisors.plans,
                first.supervisor.config,
            )  # fmt: skip
            labels = (self._labels, going)
            info = step_infos(self.envs, worlds, faults, worlds.lights, infos, events, labels)
        else:
            info = batch_infos(infos, n)
        return self._observations(), rewards, terminated, truncated, info

    def _step_alone(self, actions):
        """`step` of a batch of one: the scalar env's own step (its action checked with
        the batch, then clipped), with the same autoresets and infos."""
        env, limit = self.envs[0], self.max_episode_steps
        rewards, terminated, truncated = [0.0], [False], [False]
        infos: dict[int, dict] = {}
        stepping = ~self._ended
        if stepping[0]:
            obs, rewards[0], terminated[0], _, infos[0] = env._step_valid(
                self._valid(env, actions[0])
            )
            self._elapsed[0] += 1
            truncated[0] = limit is not None and self._elapsed[0] >= limit
            self._write(0, obs)
        self._autoreset(stepping, terminated, truncated, infos)
        return (
            self._observations(),
            np.array(rewards, dtype=np.float64),
            np.array(terminated, dtype=np.bool_),
            np.array(truncated, dtype=np.bool_),
            batch_infos(infos, 1),
        )

    def _episode_scores(self, ending, terminated, events, infos: dict[int, dict]) -> None:
        """Each `ending` world's driving score entries into its own info, from its env's
        `_episode_score` (the rule is the scalar env's; a world timed out when its env's
        `time_limit` is reached, as in the scalar env)."""
        for i in ending.nonzero()[0].tolist():
            report = self.envs[i]._episode_score(events[i], bool(terminated[i]))
            if report:
                infos.setdefault(i, {}).update(report)

    def _act_all(self, actions, stepping, worlds, supervisors) -> None:
        """Every stepping world's controls into `worlds.controls`, in array operations for
        all worlds at every level (`decode.act`, one row per world whose ego drives: after
        arriving, in "all" mode, its action is ignored; the batch is checked)."""
        first = self.envs[0]
        rows = (stepping & worlds["active"][:, 0]).nonzero()[0]
        values = actions[rows]
        if self._bound_arrays is not None:  # Box: clipped, in physical units
            values = values.reshape(len(rows), *self._bound_arrays[0].shape).astype(np.float64)
            values = decode.clip(values, *self._bound_arrays)
            if first.action_scale == "normalized":
                values = decode.to_physical(first.action_level, first.world, values)
        pilots = decode.Pilots.of_batch(supervisors)
        changed = decode.act(
            first.action_level, rows, np.zeros_like(rows), values, stepping, worlds, pilots,
            worlds.controls,
        )  # fmt: skip
        for i in rows[changed].tolist():  # a behaviour action changed the ego's route
            env = self.envs[i]
            env._route_length = float(rules.route_length(env.world.path_len[0], env._last_s))

    def _autoreset(self, stepping, terminated, truncated, infos) -> None:
        """Reset the worlds that ended on the previous step (next-step autoreset) or, with
        `"SameStep"`, on this one (their final observation and info kept in their info);
        record which ended."""
        mode = self.autoreset_mode
        ended = np.logical_or(terminated, truncated)
        resetting = ~stepping | (ended if mode is AutoresetMode.SAME_STEP else False)
        for i in resetting.nonzero()[0].tolist():
            env = self.envs[i]
            if not stepping[i]:
                obs, infos[i] = env.reset()
            else:  # "SameStep": the final observation and info, then the reset's
                infos[i] = {"final_obs": self._read(i), "final_info": infos.get(i)}
                obs, reset_info = env.reset()
                infos[i].update(reset_info)
            self._write(i, obs)
            self._elapsed[i] = 0
        self._stale |= resetting
        if mode is not AutoresetMode.SAME_STEP:
            self._ended = ended

    def render(self) -> tuple[np.ndarray, ...] | None:
        """One frame per world (`render_mode="rgb_array"`)."""
        if self.render_mode is None:
            return self.envs[0].render()  # the scalar env's warning, and None
        return tuple(env.render() for env in self.envs)

    def close_extras(self, **kwargs: Any) -> None:
        # an env whose __init__ refused its arguments has no worlds (Gymnasium 1.0's __del__
        # still closes it)
        for env in getattr(self, "envs", ()):
            env.close()

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Each world's `name` (called with the arguments if it is a method), as
        `SyncVectorEnv.call` gives it."""
        values = [getattr(env, name) for env in self.envs]
        self._stale[:] = True  # a method may have given an env new objects
        return tuple(v(*args, **kwargs) if callable(v) else v for v in values)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        return self.call(name)

    def set_attr(self, name: str, values: Any) -> None:
        """Set `name` on every world: one value each from a list or tuple of `num_envs`,
        else the same value on all (as `SyncVectorEnv.set_attr`)."""
        values = attribute_values(values, self.num_envs)
        for env, value in zip(self.envs, values, strict=True):
            setattr(env, name, value)
        self._stale[:] = True

    # ------------------------------------------------------------------ supervisor and state
    def supervisor_action(self) -> np.ndarray:
        """Every world's supervisor label in its current state, batched like
        `info["supervisor_action"]`."""
        labels = [env.supervisor_action() for env in self.envs]
        return batch_infos([{SUPERVISOR_ACTION_KEY: a} for a in labels], self.num_envs)[
            SUPERVISOR_ACTION_KEY
        ]

    def snapshot(self, index: int) -> WrappedSnapshot:
        """World `index`'s state, as `fluids_bench.core.snapshot.snapshot` gives it for a
        `gym.make` env of the same id (restore it there, or here with `restore`)."""
        env = self.envs[world_index(index, self.num_envs)]
        counters = {
            "TimeLimit": {"_elapsed_steps": int(self._elapsed[index])},
            "OrderEnforcing": {"_has_reset": self._has_reset},
            "PassiveEnvChecker": {},
        }
        names = MAKE_WRAPPERS if self.max_episode_steps is not None else MAKE_WRAPPERS[1:]
        return WrappedSnapshot(env.snapshot(), tuple((k, counters[k]) for k in names))

    def restore(self, index: int, snap: WrappedSnapshot) -> None:
        """Continue world `index` from `snap` (from `snapshot` or from
        `fluids_bench.core.snapshot.snapshot` of a `gym.make` env of the same id and
        kwargs); its next step is the one that env would take."""
        env = self.envs[world_index(index, self.num_envs)]
        if not isinstance(snap, WrappedSnapshot):
            raise TypeError(
                f"{WHERE}.restore: snap is {type(snap).__name__}; allowed: a WrappedSnapshot "
                "from FluidsVectorEnv.snapshot(i) or fluids_bench.core.snapshot.snapshot(env)"
            )
        env.restore(snap.env)
        counters = dict(snap.wrappers)
        elapsed = int(counters.get("TimeLimit", {}).get("_elapsed_steps") or 0)
        limit = self.max_episode_steps
        self._elapsed[index] = elapsed
        self._ended[index] = bool(env._ended) or (limit is not None and elapsed >= limit)
        self._stale[index] = True
        self._has_reset = True

    # ------------------------------------------------------------------ helpers
    def _bound_batches(self) -> tuple[WorldBatch, FaultBatch, SupervisorBatch]:
        """The row storage of the worlds, their fault trackers and their supervisors, with
        every one the envs now hold bound to it (a reset, a restore or a `call` gives an env
        new ones, bound here before they step)."""
        worlds, faults, supervisors = self._worlds, self._faults, self._supervisors
        for i in self._stale.nonzero()[0].tolist():
            env = self.envs[i]
            if worlds.worlds[i] is not env.world:
                worlds.bind(i, env.world)
            if faults.trackers[i] is not env.faults:
                faults.bind(i, env.faults)
            if supervisors.supervisors[i] is not env.supervisor:
                supervisors.bind(i, env.supervisor)
        self._stale[:] = False
        return worlds, faults, supervisors

    def _valid(self, env: FluidsEnv, action: np.ndarray):
        """World `env`'s row of a checked batch as `levels.validate` returns it."""
        if self._bounds is None:  # Discrete: an integer in range (check_batch)
            return int(action)
        values = action.reshape(-1).tolist()
        return levels.clip(env.action_level, values, self._bounds, env.world, env.action_scale)

    def _observe(self, stepping, index, worlds: WorldBatch, lights: np.ndarray) -> None:
        """Write the observation of every world that stepped (`index`: where `stepping`;
        `lights`: their light states) into the batch: one call for all when the observation
        allows it, else world by world (a noisy or image observation, drawn with each world's
        own generator)."""
        if self._batchable and index:
            rows = self.envs[0].observer.observe_worlds(stepping, worlds, lights)
            if len(index) == self.num_envs:  # every world stepped: no fancy-indexed write
                self._obs[...] = rows
            else:
                self._obs[stepping] = rows
            return
        for i in index:
            self._write(i, self.envs[i]._observe())

    def _read(self, i: int) -> Any:
        """World `i`'s row of the batched observation, as the scalar env returns it."""
        if self._dict_obs:
            return {key: value[i].copy() for key, value in self._obs.items()}
        return self._obs[i].copy()

    def _write(self, i: int, obs: Any) -> None:
        if self._dict_obs:
            for key, value in obs.items():
                self._obs[key][i] = value
        else:
            self._obs[i] = obs

    def _observations(self):
        if self._dict_obs:
            return {key: value.copy() for key, value in self._obs.items()}
        return self._obs.copy()
