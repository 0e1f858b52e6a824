"""DrivingTrack-v0: the polygonal driving track of the source's SHIV experiments (ch. 6)."""

from __future__ import annotations

import functools
import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from fluids_bench.core.actions import check_action
from fluids_bench.core.snapshot import SnapshotMixin
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.core.validation import (
    REWARD_LIMIT,
    as_seed,
    check_choice,
    check_float,
    check_int,
    fail,
    reject_unknown_kwargs,
)
from fluids_bench.tasks.track.features import HOG_DIM, IMAGE_SIZE, BirdsEye, hog_descriptor
from fluids_bench.tasks.track.sim import TrackConfig, TrackSim, generate_track, wrap_heading
from fluids_bench.tasks.track.supervisor import DEFAULT_PROGRESS_WEIGHT, SearchSupervisor

WHERE = "DrivingTrack-v0"
OBS_TYPES = ("hog", "pixels", "state")
DEFAULT_DEPTH = 8
# centre-line look-ahead of the state observation, in car steps ahead
LOOKAHEAD_STEPS = np.array([1.0, 2.0, 4.0, 8.0])
STATE_DIM = 6 + 2 * len(LOOKAHEAD_STEPS)
STATE_BOUND = 50.0  # loose bound of every state feature (look-ahead points reach ~10 steps)
# ``edges=e``: Gaussian samples drawn per track try, chosen so that a hull of exactly e edges
# comes up in >= 1 try in 20 (measured: 2,000 hulls per sample count)
POINTS_FOR_EDGES = {3: 6, 4: 6, 5: 10, 6: 14, 7: 20, 8: 30, 9: 50}


@functools.cache
def _hog():
    # one descriptor per process (an OpenCV object does not pickle; it holds no state)
    return hog_descriptor()


def _python_scalars(init):
    """Accept numpy scalars wherever a number is expected (`np.int64(3)` as `3`)."""

    @functools.wraps(init)
    def converted(self, *args: Any, **kwargs: Any) -> None:
        kwargs = {k: v.item() if isinstance(v, np.generic) else v for k, v in kwargs.items()}
        init(self, *args, **kwargs)

    return converted


class DrivingTrackEnv(SnapshotMixin, gym.Env[Any, np.int64]):
    """
    ## Description

    A car drives at constant speed around a random convex polygonal track, seen from above
    (the driving simulator of the dissertation's ch. 6, where SHIV and DAgger learn a linear
    SVM policy on HOG features of the bird's-eye image). The track is the convex hull of points
    drawn from a Gaussian centred in a 500×500 workspace, kept when it has 5 to 7 edges, with a
    road of half-width `half_width` around it. Leaving the road is a crash: the car is put back
    on the centre line `reset_ahead` units beyond the point where it left, heading along the
    road, and the crash is counted. The source's performance measure is crashes per lap.

    The supervisor (`supervisor_action()`, `info["supervisor_action"]`) searches every
    steering sequence of `depth` steps through the car's model and returns the first action of
    the best one (`fluids_bench.tasks.track.supervisor`). Depth is its quality knob: at the
    default 8 it crashes 0.24 times per lap, at depth 1 2.56 times (200 tracks; the README's
    quality table). `DrivingTrack-Source-v0` sets depth 1, the most crash-prone search, as the
    stand-in for the source's imperfect supervisor (5.4 crashes per lap there: no depth of this
    search crashes that often, see the README).

    ## Action Space

    `Discrete(3)`: the heading changes instantly by 0: -15°, 1: 0°, 2: +15° (counter-clockwise
    positive), then the car moves `speed` units.

    ## Observation Space

    `obs_type` selects it (a list of several gives a `Dict` with those keys):

    - `"hog"` (default): `Box(0, 1, (20736,), float32)`, OpenCV's HOG descriptor of the
      125×125 RGB bird's-eye image (window 125×125, cells 5×5, blocks 2×2 cells moved by one
      cell, 9 bins; `fluids_bench.tasks.track.features`). The source reports 27,926 dimensions
      with unstated parameters. Needs OpenCV's contrib wheel (`cv2.HOGDescriptor`).
    - `"pixels"`: `Box(0, 255, (125, 125, 3), uint8)`, the whole workspace drawn at 500×500 and
      downsampled by two Gaussian-pyramid steps, as the source.
    - `"state"`: `Box(-50, 50, (14,), float32)`: x / 500, y / 500, cos and sin of the heading,
      signed distance from the centre line / `half_width` (left positive), heading error from
      the road (rad), and the centre-line points 1, 2, 4 and 8 steps ahead in the car's frame
      (x forward, y left), in units of `speed`.

    ## Rewards

    `-crash_penalty` (1) for each crash, plus `progress_reward` (0) per lap of progress, so by
    default the return is minus the number of crashes (the source's measure).

    ## Starting State

    On the centre line at a uniformly drawn arc length, heading along the road. Each
    `reset(seed=...)` draws a new track from the episode's generator unless `track_seed` fixes
    one (then only the start varies), so "40 different tracks" is a loop over `track_seed`.

    ## Episode End

    Termination after `laps` (2) laps, as the source's supervisor drove twice around the
    track. Truncation after 600 steps (`max_episode_steps`); two laps take about 180 steps.

    `info`: `supervisor_action`, `crashes` (this episode), `laps` (fractional), `lap_crashes`
    (crashes in the lap under way), `crashed` (this step), `is_success` (a lap was completed
    without a crash).

    ## Snapshots and labels

    `env.unwrapped.snapshot()` returns a picklable state (the track, the car, the lap
    bookkeeping and `np_random`); `restore(snapshot)` on another env built with the same
    kwargs (reset with any seed) continues bit-identically. The label (a depth-limited search
    from the car's pose) is a function of the track and the car's pose.

    ## Arguments

    The keyword arguments of `__init__`, each described in its `Args:`. Numbers may be Python
    or numpy scalars; a bad value raises `ValueError` naming it and what is allowed, an
    unknown argument `TypeError` (also a `ValueError`) listing the allowed ones.

    ```python
    >>> import gymnasium as gym, fluids_bench
    >>> env = gym.make("DrivingTrack-v0", track_seed=3)
    >>> obs, info = env.reset(seed=0)
    >>> obs, reward, terminated, truncated, info = env.step(info["supervisor_action"])
    ```

    ## Version History

    * v0: Initial version.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    # the track (a new one every episode unless track_seed is given), the car, the search
    # supervisor and the lap bookkeeping; a fixed track is built from the kwargs and kept
    _snapshot_fields = ("track", "sim", "supervisor", "view", "_lap_start_crashes", "_clean_laps")

    def _snapshot_static(self) -> dict[str, Any]:
        return {} if self._fixed_track is None else {"track": self._fixed_track}

    @reject_unknown_kwargs
    @_python_scalars
    def __init__(
        self,
        obs_type: str | list[str] = "hog",
        depth: int = DEFAULT_DEPTH,
        track_seed: int | None = None,
        laps: int = 2,
        half_width: float = 15.0,
        speed: float = 10.0,
        reset_ahead: float = 10.0,
        crash_penalty: float = 1.0,
        progress_reward: float = 0.0,
        edges: int | None = None,
        obs_noise: float = 0.0,
        render_mode: str | None = None,
    ) -> None:
        """Build the driving track task.

        Args:
            obs_type: `"hog"`, `"pixels"`, `"state"`, or a list of them (a `Dict` space).
            depth: The supervisor's look-ahead, in steps.
            track_seed: Fixes the track; `None`: a new one at each reset.
            laps: Laps per episode.
            half_width: Half-width of the road (track units).
            speed: Distance per step (track units).
            reset_ahead: How far ahead a crashed car is put back (track units).
            crash_penalty: Reward lost per crash.
            progress_reward: Reward per lap of progress.
            edges: Every track has exactly this many edges; `None`: 5 to 7.
            obs_noise: Camera noise: N(0, σ²) added to each observation element (pixels:
                σ × 255), clipped to the bounds.
            render_mode: `None` or `"rgb_array"` (500×500).
        """
        allowed_kinds = f"one of {list(OBS_TYPES)} or a list of them"
        if not isinstance(obs_type, str | list | tuple):
            fail(WHERE, "obs_type", obs_type, allowed_kinds)
        kinds = [obs_type] if isinstance(obs_type, str) else list(obs_type)
        if not kinds or len(set(kinds)) != len(kinds):
            fail(WHERE, "obs_type", obs_type, allowed_kinds)
        for kind in kinds:
            check_choice(WHERE, "obs_type", kind, OBS_TYPES)
        self.obs_type = obs_type if isinstance(obs_type, str) else kinds
        self._kinds = kinds
        self.depth = check_int(WHERE, "depth", depth, 1, 12)
        self.track_seed = (
            None if track_seed is None else check_int(WHERE, "track_seed", track_seed, 0)
        )
        self.laps = check_int(WHERE, "laps", laps, 1, 100)
        shape: dict[str, int] = {}  # None: TrackConfig's 5-7 edges from 10 samples
        if edges is not None:
            e = check_int(WHERE, "edges", edges, min(POINTS_FOR_EDGES), max(POINTS_FOR_EDGES))
            shape = {"min_edges": e, "max_edges": e, "points": POINTS_FOR_EDGES[e]}
        self.obs_noise = check_float(WHERE, "obs_noise", obs_noise, 0.0, 1.0)
        self.config = TrackConfig(
            half_width=check_float(WHERE, "half_width", half_width, 0.0, 125.0, lo_open=True),
            speed=check_float(WHERE, "speed", speed, 0.0, 125.0, lo_open=True),
            reset_ahead=check_float(WHERE, "reset_ahead", reset_ahead, 0.0, 500.0),
            **shape,
        )
        self.crash_penalty = check_float(WHERE, "crash_penalty", crash_penalty, 0.0, REWARD_LIMIT)
        self.progress_reward = check_float(
            WHERE, "progress_reward", progress_reward, 0.0, REWARD_LIMIT
        )
        self.render_mode = check_choice(WHERE, "render_mode", render_mode, [None, "rgb_array"])

        self.action_space = spaces.Discrete(3)
        boxes = {
            "hog": spaces.Box(0.0, 1.0, (HOG_DIM,), np.float32),
            "pixels": spaces.Box(0, 255, (IMAGE_SIZE, IMAGE_SIZE, 3), np.uint8),
            "state": spaces.Box(-STATE_BOUND, STATE_BOUND, (STATE_DIM,), np.float32),
        }
        if isinstance(self.obs_type, str):
            self.observation_space = boxes[self.obs_type]
        else:
            self.observation_space = spaces.Dict({k: boxes[k] for k in kinds})
        if "hog" in kinds:
            _hog()  # fail now, with the install hint, if this OpenCV has no HOG
        self._fixed_track = None
        if self.track_seed is not None:
            self._fixed_track = generate_track(np.random.default_rng(self.track_seed), self.config)
        self._setup(self._fixed_track or generate_track(np.random.default_rng(0), self.config))

    def _setup(self, track) -> None:
        self.track = track
        self.sim = TrackSim(track, self.config)
        self.supervisor = SearchSupervisor(track, self.config, self.depth, DEFAULT_PROGRESS_WEIGHT)
        self.view = BirdsEye(track, self.config.workspace) if self._needs_image() else None
        self._lap_start_crashes = 0
        self._clean_laps = 0

    def _needs_image(self) -> bool:
        return "hog" in self._kinds or "pixels" in self._kinds or self.render_mode == "rgb_array"

    # -- observations and labels ---------------------------------------------------------------

    def _state_vector(self) -> np.ndarray:
        car, track = self.sim.car, self.track
        distance, _, seg = track.project(car.x, car.y)
        dx, dy = car.x - track.vertices[seg, 0], car.y - track.vertices[seg, 1]
        side = track.directions[seg, 0] * dy - track.directions[seg, 1] * dx
        signed = math.copysign(distance, side) / track.half_width
        error = wrap_heading(car.heading - track.headings[seg])
        ahead = self.sim.lookahead(LOOKAHEAD_STEPS * self.config.speed) / self.config.speed
        head = [car.x / self.config.workspace, car.y / self.config.workspace]
        head += [math.cos(car.heading), math.sin(car.heading), signed, error]
        return np.concatenate([head, ahead]).astype(np.float32)

    def _observation(self) -> Any:
        car = self.sim.car
        obs: dict[str, np.ndarray] = {}
        if "hog" in self._kinds or "pixels" in self._kinds:
            assert self.view is not None
            image = self.view.frame(car.x, car.y, car.heading)  # a new array each call
            if "pixels" in self._kinds:
                obs["pixels"] = image
            if "hog" in self._kinds:
                obs["hog"] = _hog().compute(image).reshape(-1)
        if "state" in self._kinds:
            obs["state"] = self._state_vector()
        if self.obs_noise > 0.0:  # camera / sensor noise (drawn only when asked for)
            obs = {kind: self._noisy(kind, value) for kind, value in obs.items()}
        return obs[self.obs_type] if isinstance(self.obs_type, str) else obs

    def _noisy(self, kind: str, value: np.ndarray) -> np.ndarray:
        """`value` plus N(0, obs_noise²) per element (pixels: × 255, rounded), clipped to the
        observation's bounds; from the episode's `np_random`."""
        noise = self.np_random.normal(0.0, self.obs_noise, value.shape)
        if kind == "pixels":
            return np.clip(np.rint(value + 255.0 * noise), 0, 255).astype(np.uint8)
        bound = STATE_BOUND if kind == "state" else None
        noisy = value + noise
        noisy = np.clip(noisy, -bound, bound) if bound else np.clip(noisy, 0.0, 1.0)
        return noisy.astype(np.float32)

    def supervisor_action(self) -> np.int64:
        """The depth-limited search's steering action in the current state."""
        car = self.sim.car
        return np.int64(self.supervisor.action(car.x, car.y, car.heading))

    def _info(self, crashed: bool) -> dict[str, Any]:
        car = self.sim.car
        return {
            SUPERVISOR_ACTION_KEY: self.supervisor_action(),
            "crashes": car.crashes,
            "laps": self.sim.laps,
            "lap_crashes": car.crashes - self._lap_start_crashes,
            "crashed": crashed,
            "is_success": self._clean_laps > 0,
        }

    # -- the Gymnasium API ---------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        seed = as_seed(seed)  # np.int64(5) seeds as 5
        super().reset(seed=seed)
        if self._fixed_track is None:
            self._setup(generate_track(self.np_random, self.config))
        else:
            self.sim = TrackSim(self.track, self.config)
        self._lap_start_crashes = self._clean_laps = 0
        self.sim.place(float(self.np_random.uniform(0.0, self.track.perimeter)))
        return self._observation(), self._info(False)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        index = check_action(WHERE, self.action_space, action)
        laps_before = self.sim.laps
        crashed = self.sim.step(index)
        laps_now = self.sim.laps
        if math.floor(laps_now) > math.floor(laps_before):  # a lap completed
            if self.sim.car.crashes == self._lap_start_crashes:
                self._clean_laps += 1
            self._lap_start_crashes = self.sim.car.crashes
        reward = self.progress_reward * (laps_now - laps_before) - self.crash_penalty * crashed
        terminated = laps_now >= self.laps
        return self._observation(), float(reward), terminated, False, self._info(crashed)

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        assert self.view is not None
        car = self.sim.car
        return self.view.full_frame(car.x, car.y, car.heading)
