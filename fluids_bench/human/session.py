"""The teleop and relabel sessions: a person (in a window) or a simulated person acts or labels.

`teleop` runs episodes of an env, a person acting through its control scheme
(`controls`) in a window, or a `SimulatedHuman` without one,
and returns the finished episodes (`Episode`). The
window steps the env `fps` times a second (half that in slow motion); `p` pauses, `r`
restarts the episode (the unfinished one is dropped), `l` shows the supervisor's label. Esc,
`q`, closing the window or Ctrl-C end the session: the finished episodes are kept, the
unfinished one is dropped (`TeleopResult.ended` says how it ended).

`relabel` shows the states of a dataset's episodes one by one, rebuilt from the stored
env states (`StateRebuilder`), and takes a label for each
with the same controls: a key of the scheme's (arrows, space, ...) or a click labels the state
and moves on, Return labels it with the held input, Backspace goes back.

`script` (tests, screenshots) is called once per window frame with the session, before the
events are read: it can post pygame events or stop the session.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from fluids_bench.core import snapshot as snap
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY, supervisor_action
from fluids_bench.human.controls import Scheme, check_teleop_id, scheme_for
from fluids_bench.human.recording import Episode, StateRebuilder
from fluids_bench.human.simulated import NoiseInjector, SimulatedHuman

NOISE_STREAM = 0x4E015E


def _label(env: gym.Env, info: dict[str, Any]) -> Any:
    if SUPERVISOR_ACTION_KEY in info:
        return info[SUPERVISOR_ACTION_KEY]
    return supervisor_action(env)


def describe_action(space: spaces.Space, action: Any, names: tuple[str, ...] = ()) -> str:
    if isinstance(space, spaces.Discrete):
        a = int(action)
        return f"{a} ({names[a]})" if a < len(names) else str(a)
    return "[" + ", ".join(f"{v:+.2f}" for v in np.asarray(action).reshape(-1)) + "]"


@dataclass
class TeleopResult:
    episodes: list[Episode]
    ended: str  # "done" (all episodes), "quit" (Esc / q / window closed), "interrupted"
    seconds: float
    steps: int
    noise_levels: list[float] = field(default_factory=list)


class Teleop:
    """One teleop session (see the module docstring); `run` returns a TeleopResult."""

    def __init__(
        self,
        env_id: str,
        env_kwargs: dict[str, Any] | None = None,
        *,
        episodes: int = 1,
        seed: int = 0,
        max_steps: int | None = None,
        fps: float | None = None,
        snapshot_every: int = 10,
        show_label: bool = False,
        noise: float | str | None = None,
        dart_alpha: float | None = None,
        human: SimulatedHuman | None = None,
        script: Callable[[Teleop], None] | None = None,
    ) -> None:
        check_teleop_id(env_id)
        self.env = gym.make(env_id, render_mode="rgb_array", **dict(env_kwargs or {}))
        self.scheme: Scheme = scheme_for(self.env)  # ValueError: no teleop mapping
        self.space = self.env.action_space
        self.episodes_wanted, self.seed, self.max_steps = episodes, seed, max_steps
        self.fps = fps or self.scheme.fps
        self.snapshot_every = snapshot_every
        self.show_label = show_label
        self.noise = NoiseInjector(self.space, noise, alpha=dart_alpha)
        self.human, self.script = human, script
        self.window = None
        self.paused = self.slow = False
        self.finished: list[Episode] = []
        self.current: Episode | None = None
        self.stop = False  # a script may set it

    # -- episodes ---------------------------------------------------------------------------
    def _start(self) -> None:
        seed = self.seed + len(self.finished)
        observation, info = self.env.reset(seed=seed)
        self.scheme.reset()
        if self.human is not None:
            self.human.reset()
        self.rng = np.random.default_rng([seed, NOISE_STREAM])
        self.info = info
        self.current = Episode(seed=seed, observations=[observation])
        self.current.infos = {
            "executed_action": [],
            "provenance": ["reset"],
            "supervisor_action": [_label(self.env, info)],
            "time": [time.perf_counter() - self.t0],
            "reaction_time": [math.nan],
            "noise_level": [self.noise.level],
        }
        self.current.states[0] = snap.snapshot(self.env)
        self.shown_at = time.perf_counter()

    def _step(self, intended: Any, reaction: float) -> bool:
        """Execute one step; True when the episode ended."""
        ep, info = self.current, self.info
        label = _label(self.env, info)
        executed = self.noise(intended, self.rng)
        if isinstance(self.space, spaces.Discrete):
            intended, executed = np.int64(intended), np.int64(executed)
        else:
            intended = np.asarray(intended, dtype=self.space.dtype)
            executed = np.asarray(executed, dtype=self.space.dtype)
        observation, reward, terminated, truncated, info = self.env.step(executed)
        self.info = info
        t = len(ep.actions)
        ep.observations.append(observation)
        ep.actions.append(intended)
        ep.rewards.append(float(reward))
        who = "human" if self.human is None else "simulated_human"
        if self.noise.active:
            who += "_noise"
        column = ep.infos
        if not column["executed_action"]:
            column["executed_action"].append(np.zeros_like(executed))
        column["executed_action"].append(executed)
        column["provenance"].append(who)
        column["supervisor_action"].append(label)
        column["time"].append(time.perf_counter() - self.t0)
        column["reaction_time"].append(reaction)
        column["noise_level"].append(self.noise.level)
        if (t + 1) % self.snapshot_every == 0:
            ep.states[t + 1] = snap.snapshot(self.env)
        self.shown_at = time.perf_counter()
        done = terminated or truncated
        if self.max_steps is not None and t + 1 >= self.max_steps:
            done = True
        if done:
            ep.terminated, ep.truncated = bool(terminated), not terminated
            self.finished.append(ep)
            self.noise.update(self.finished)
            self.current = None
        return done

    # -- the loops --------------------------------------------------------------------------
    def run(self) -> TeleopResult:
        self.t0 = time.perf_counter()
        ended = "done"
        steps = 0
        try:
            if self.human is not None:
                steps = self._run_simulated()
            else:
                ended, steps = self._run_window()
        except KeyboardInterrupt:
            ended = "interrupted"
        finally:
            if self.window is not None:
                self.window.close()
            self.env.close()
        return TeleopResult(self.finished, ended, time.perf_counter() - self.t0, steps)

    def _run_simulated(self) -> int:
        steps = 0
        dt = 1.0 / self.fps
        while len(self.finished) < self.episodes_wanted and not self.stop:
            if self.current is None:
                self._start()
            if self.script is not None:
                self.script(self)
            label = _label(self.env, self.info)
            action = self.human.act(self.space, label, self.rng)
            self._step(action, self.human.delay * dt)
            steps += 1
        return steps

    def status(self) -> list[str]:
        ep = self.current
        t = 0 if ep is None else len(ep.actions)
        flags = [s for s, on in (("PAUSED", self.paused), ("SLOW", self.slow)) if on]
        noise = f"  noise {self.noise.level:.3g}" if self.noise.active else ""
        return [
            f"episode {len(self.finished) + 1}/{self.episodes_wanted}  step {t}  "
            f"seed {self.seed + len(self.finished)}  {' '.join(flags)}{noise}",
            f"{self.scheme.name}: " + "; ".join(self.scheme.help),
            "p pause  s slow  r restart  l label  esc quit",
        ]

    def _run_window(self) -> tuple[str, int]:
        from fluids_bench.human.window import Window

        self.window = window = Window(
            f"fluids-bench teleop {self.env.spec.id}", "fluids-bench teleop"
        )
        steps = 0
        next_step = time.perf_counter()
        first_input: float | None = None
        frame_for: tuple[int, int] | None = None
        while len(self.finished) < self.episodes_wanted:
            if self.current is None:
                self._start()
                first_input = None
            if self.script is not None:
                self.script(self)
            if self.stop:
                return "quit", steps
            commands, pressed = window.poll()
            for key in (k for kind, k in pressed if kind == "key"):
                self.scheme.key_pressed(key)
            if pressed and first_input is None and window.last_input_time is not None:
                first_input = window.last_input_time
            if "quit" in commands:
                return "quit", steps
            self.paused ^= commands.count("pause") % 2 == 1
            self.slow ^= commands.count("slow") % 2 == 1
            self.show_label ^= commands.count("overlay") % 2 == 1
            if "restart" in commands:
                self.current = None  # dropped; the same seed starts again
                continue
            overlay = None
            if self.show_label:
                label = describe_action(
                    self.space, _label(self.env, self.info), self.scheme.action_names
                )
                overlay = f"supervisor: {label}"
            where = (id(self.current), len(self.current.actions))
            if where != frame_for:  # draw the env only when it changed
                frame, frame_for = self.env.render(), where
            window.show(frame, self.status(), overlay)
            now = time.perf_counter()
            if self.paused or now < next_step:
                time.sleep(min(0.005, max(0.0, next_step - now)))
                continue
            next_step = now + (2.0 if self.slow else 1.0) / self.fps
            if (
                first_input is None
                and window.last_input_time is not None
                and window.last_input_time >= self.shown_at
            ):
                first_input = window.last_input_time
            reaction = math.nan if first_input is None else max(0.0, first_input - self.shown_at)
            self._step(self.scheme.action(window.inputs), reaction)
            first_input = None
            steps += 1
        return "done", steps


# -- relabelling -----------------------------------------------------------------------------


@dataclass
class RelabelResult:
    labels: dict[tuple[int, int], tuple[Any, float]]  # (episode, t) -> (label, seconds taken)
    ended: str
    seconds: float

    @property
    def labels_per_minute(self) -> float:
        return 60.0 * len(self.labels) / self.seconds if self.seconds > 0 else 0.0


class Relabel:
    """One relabelling session over `episodes` (from `recording.load_episodes`)."""

    def __init__(
        self,
        spec,
        episodes: list[Episode],
        dataset_id: str,
        *,
        items: list[tuple[int, int]] | None = None,
        human: SimulatedHuman | None = None,
        seed: int = 0,
        show_label: bool = False,
        script: Callable[[Relabel], None] | None = None,
    ) -> None:
        if human is None:
            check_teleop_id(spec.id)  # a person needs the env's controls and pictures
        self.rebuilder = StateRebuilder(
            spec, episodes, dataset_id, render_mode=None if human else "rgb_array"
        )
        self.env = self.rebuilder.env
        self.scheme = None if human is not None else scheme_for(self.env)
        self.space = self.env.action_space
        self.episodes = episodes
        self.items = items or [(e, t) for e, ep in enumerate(episodes) for t in range(len(ep))]
        self.human, self.seed, self.show_label, self.script = human, seed, show_label, script
        self.index = 0
        self.labels: dict[tuple[int, int], tuple[Any, float]] = {}
        self.window = None
        self.stop = False

    def run(self) -> RelabelResult:
        t0 = time.perf_counter()
        ended = "done"
        try:
            if self.human is not None:
                self._run_simulated()
            else:
                ended = self._run_window()
        except KeyboardInterrupt:
            ended = "interrupted"
        finally:
            if self.window is not None:
                self.window.close()
            self.rebuilder.close()
        return RelabelResult(self.labels, ended, time.perf_counter() - t0)

    def _run_simulated(self) -> None:
        rng = np.random.default_rng([self.seed, NOISE_STREAM])
        for e, t in self.items:
            if self.stop:
                break
            started = time.perf_counter()
            self.rebuilder.go(e, t)
            label = self.human.label(self.space, supervisor_action(self.env), rng)
            self.labels[(e, t)] = (label, time.perf_counter() - started)

    def status(self) -> list[str]:
        e, t = self.items[self.index]
        names = self.scheme.action_names
        original = describe_action(self.space, self.episodes[e].actions[t], names)
        mine = self.labels.get((e, t))
        given = (
            "" if mine is None else f"  your label {describe_action(self.space, mine[0], names)}"
        )
        return [
            f"state {self.index + 1}/{len(self.items)}: episode {e} step {t}  "
            f"recorded {original}{given}",
            f"{self.scheme.name}: " + "; ".join(self.scheme.help),
            "a control key or click labels; return: label held input; backspace back; esc quit",
        ]

    def _run_window(self) -> str:
        from fluids_bench.human.window import Window

        self.window = window = Window(
            f"fluids-bench relabel {self.env.spec.id}", "fluids-bench relabel"
        )
        shown: tuple[int, int] | None = None
        shown_at_for: tuple[int, int] | None = None
        shown_at, dirty = 0.0, False
        while self.index < len(self.items):
            e, t = self.items[self.index]
            if shown != (e, t):
                self.rebuilder.go(e, t)
                self.scheme.reset()
                if type(self.scheme).__name__ == "FluidsVelocityScheme":
                    self.scheme.memory["target"] = float(
                        np.asarray(self.episodes[e].actions[t]).reshape(-1)[0]
                    )
                frame = self.env.render()
                shown, dirty = (e, t), True
            if dirty:  # draw before reading input: a label is for what was on screen
                overlay = None
                if self.show_label:
                    label = describe_action(
                        self.space, supervisor_action(self.env), self.scheme.action_names
                    )
                    overlay = f"supervisor: {label}"
                window.show(frame, self.status(), overlay)
                dirty = False
                shown_at = shown_at if shown_at_for == (e, t) else time.perf_counter()
                shown_at_for = (e, t)
            if self.script is not None:
                self.script(self)
            if self.stop:
                return "quit"
            commands, pressed = window.poll()
            if "quit" in commands:
                return "quit"
            if commands.count("overlay") % 2 == 1:
                self.show_label, dirty = not self.show_label, True
            if "back" in commands:
                self.index = max(0, self.index - 1)
                continue
            label = None
            for kind, what in pressed:
                if kind == "key":
                    self.scheme.key_pressed(what)
                    if what in self.scheme.confirm_keys or what == "return":
                        held = window.inputs
                        if what != "return":
                            held = held.with_keys({what})
                        label = self.scheme.action(held)
                        break
                elif kind == "click" and self.scheme.confirm_click:
                    b = window.inputs.buttons
                    label = self.scheme.action(replace(window.inputs, buttons=(True, b[1], b[2])))
                    break
            if label is not None:
                self.labels[(e, t)] = (label, time.perf_counter() - shown_at)
                self.index += 1
                continue
            time.sleep(0.002)
        return "done"
