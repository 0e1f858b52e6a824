"""The pygame window of `teleop` and `relabel`: a frame, a status bar, and the input state.

pygame is the optional `human` extra. The window shows an env's `rgb_array` frame (small
frames are scaled up by a whole factor) above a status bar, and turns pygame events into an
`Inputs` plus commands: `p` pause, `s` slow motion,
`r` restart the episode, `l` toggle the supervisor's label overlay, Backspace go back
(relabel), Esc or `q` or closing the window quit. Input can be injected with
`pygame.event.post` (the tests do).

A window needs a real display: without one (on Linux, neither `DISPLAY` nor
`WAYLAND_DISPLAY` set, or SDL picking its `offscreen` or `dummy` video driver) no person
can see it, so `teleop` and `relabel` refuse to start (`require_display`) rather
than record a demonstration nobody gave. Tests that inject events under SDL's dummy driver or
Xvfb opt in with the environment variable `FLUIDS_BENCH_HEADLESS=1`.
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import replace
from typing import Any

import numpy as np

from fluids_bench.human.controls import Inputs

HUMAN_MISSING = 'the teleop and relabel windows need pygame, an optional extra: pip install "fluids-bench[human]"'
STATUS_HEIGHT = 66
MIN_SIDE = 400  # frames smaller than this are scaled up by a whole factor


def require_pygame():
    """Import pygame, or raise ImportError naming the `human` extra."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    try:
        import pygame
    except ImportError as exc:
        raise ImportError(HUMAN_MISSING) from exc
    return pygame


HEADLESS_ENV = "FLUIDS_BENCH_HEADLESS"  # "1": run the window without a display (tests)
NO_SCREEN_DRIVERS = ("offscreen", "dummy")


def headless_allowed() -> bool:
    """Whether the headless opt-in (`FLUIDS_BENCH_HEADLESS=1`) is set."""
    return os.environ.get(HEADLESS_ENV) == "1"


def _no_display_reason(driver: str | None = None) -> str | None:
    """Why there is no display a person could see, or None when there seems to be one."""
    requested = os.environ.get("SDL_VIDEODRIVER", "").strip().lower()
    if requested in NO_SCREEN_DRIVERS:
        return f"SDL_VIDEODRIVER={requested} shows nothing on a screen"
    if driver is not None and driver.lower() in NO_SCREEN_DRIVERS:
        return f"SDL picked its {driver!r} video driver, which shows nothing on a screen"
    if sys.platform.startswith("linux") and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        return "neither DISPLAY nor WAYLAND_DISPLAY is set"
    return None


def require_display(command: str, driver: str | None = None) -> None:
    """Raise `ValueError` when no person could see a window (see the module docstring),
    unless `FLUIDS_BENCH_HEADLESS=1`; `driver` is SDL's video driver once initialised."""
    if headless_allowed():
        return
    reason = _no_display_reason(driver)
    if reason is not None:
        raise ValueError(
            f"{command} needs a person at a real display and there is none ({reason}); run it "
            "in a desktop session, or use --simulated-human for a simulated person "
            f"(tests that inject input may set {HEADLESS_ENV}=1)"
        )


COMMAND_KEYS = {
    "p": "pause",
    "s": "slow",
    "r": "restart",
    "l": "overlay",
    "escape": "quit",
    "q": "quit",
    "backspace": "back",
}
INPUT_KEYS = {
    "left": "left",
    "right": "right",
    "up": "up",
    "down": "down",
    "space": "space",
    "left shift": "shift",
    "right shift": "shift",
    "return": "return",
    "enter": "return",
    **{str(d): str(d) for d in range(10)},
}


class Window:
    """One pygame window; `poll` reads events, `show` draws a frame and status."""

    def __init__(self, title: str, command: str = "the window") -> None:
        require_display(command)
        self.pg = pg = require_pygame()
        pg.display.init()
        try:
            require_display(command, pg.display.get_driver())
        except ValueError:
            pg.display.quit()
            raise
        pg.font.init()
        pg.joystick.init()
        self.joysticks = [pg.joystick.Joystick(i) for i in range(pg.joystick.get_count())]
        pg.display.set_caption(title)
        self.font = pg.font.Font(None, 20)
        self.screen = None
        self.scale = 1
        self.inputs = Inputs()
        self.last_input_time: float | None = None  # wall time of the latest input event
        self.events = 0  # key, button, click and joystick events so far (a person's presence)

    # -- events ----------------------------------------------------------------------------
    def poll(self) -> tuple[list[str], list[tuple[str, Any]]]:
        """Read pending events: update `inputs`; return the commands and the input
        events (`("key", name)` for a key press, `("click", button)`)."""
        pg = self.pg
        commands: list[str] = []
        pressed: list[tuple[str, Any]] = []
        keys, buttons = set(self.inputs.keys), list(self.inputs.buttons)
        mouse, axes = self.inputs.mouse, list(self.inputs.axes)
        presence = (
            pg.KEYDOWN,
            pg.MOUSEBUTTONDOWN,
            pg.JOYAXISMOTION,
            pg.JOYBUTTONDOWN,
            pg.JOYHATMOTION,
        )
        for event in pg.event.get():
            now = time.perf_counter()
            self.events += event.type in presence
            if event.type == pg.QUIT:
                commands.append("quit")
            elif event.type in (pg.KEYDOWN, pg.KEYUP):
                name = pg.key.name(event.key)
                down = event.type == pg.KEYDOWN
                if name in INPUT_KEYS:
                    key = INPUT_KEYS[name]
                    (keys.add if down else keys.discard)(key)
                    if down:
                        pressed.append(("key", key))
                    self.last_input_time = now
                elif down and name in COMMAND_KEYS:
                    commands.append(COMMAND_KEYS[name])
            elif event.type in (pg.MOUSEBUTTONDOWN, pg.MOUSEBUTTONUP):
                if event.button in (1, 2, 3):
                    buttons[event.button - 1] = event.type == pg.MOUSEBUTTONDOWN
                    mouse = self._frame_xy(event.pos)
                    if event.type == pg.MOUSEBUTTONDOWN:
                        pressed.append(("click", event.button))
                    self.last_input_time = now
            elif event.type == pg.MOUSEMOTION:
                mouse = self._frame_xy(event.pos)
                if any(buttons):
                    self.last_input_time = now
            elif event.type == pg.JOYAXISMOTION:
                axis = int(event.axis)
                axes.extend([0.0] * (axis + 1 - len(axes)))
                axes[axis] = float(event.value)
                self.last_input_time = now
            elif event.type == pg.JOYDEVICEADDED:
                self.joysticks.append(pg.joystick.Joystick(event.device_index))
        self.inputs = replace(
            self.inputs,
            keys=frozenset(keys),
            mouse=mouse,
            buttons=(buttons[0], buttons[1], buttons[2]),
            axes=tuple(axes),
        )
        return commands, pressed

    def _frame_xy(self, pos: tuple[int, int]) -> tuple[float, float]:
        return pos[0] / self.scale, pos[1] / self.scale

    # -- drawing ---------------------------------------------------------------------------
    def show(self, frame: np.ndarray, lines: list[str], overlay: str | None = None) -> None:
        pg = self.pg
        h, w = frame.shape[:2]
        if self.screen is None:
            self.scale = max(1, -(-MIN_SIDE // max(h, w)))
            size = (w * self.scale, h * self.scale + STATUS_HEIGHT)
            self.screen = pg.display.set_mode(size)
        surface = pg.surfarray.make_surface(np.ascontiguousarray(frame.swapaxes(0, 1)))
        if self.scale != 1:
            surface = pg.transform.scale(surface, (w * self.scale, h * self.scale))
        self.screen.fill((25, 25, 30))
        self.screen.blit(surface, (0, 0))
        if overlay:
            text = self.font.render(overlay, True, (255, 255, 255), (20, 90, 160))
            self.screen.blit(text, (w * self.scale - text.get_width() - 6, 6))  # top right
        for i, line in enumerate(lines[:3]):
            text = self.font.render(line, True, (230, 230, 230))
            self.screen.blit(text, (6, h * self.scale + 4 + 20 * i))
        pg.display.flip()

    def save(self, path) -> None:
        """Save what the window shows as a PNG."""
        self.pg.image.save(self.screen, str(path))

    def close(self) -> None:
        self.pg.display.quit()
