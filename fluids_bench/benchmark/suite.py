"""The benchmark definition: one id per task, its action level and observation, its seed
splits and its out-of-distribution (OOD) test sets.

A [`Task`][fluids_bench.benchmark.suite.Task] fixes everything an evaluation needs: the env id
and kwargs (which set the action level and the observation), how many validation and test
episodes there are, and OOD sets, each a few kwargs changed along one of the task's sweep axes
(`fluids_bench/sweep/`, `docs/results/sweep_*.json`). [`SUITE`][fluids_bench.benchmark.suite.SUITE]
is the suite; [`Suite.shortened`][fluids_bench.benchmark.suite.Suite.shortened] a smaller
evaluation of it (what CI runs), labelled as such in every scorecard.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from fluids_bench.core.splits import split_seeds

SUITE_VERSION = "1"  # bump when a task, a kwarg, a split or an OOD set changes
# The FLUIDS entry of the suite, in one place: FLUIDS-v4, v3's spaces and reward plus the driving
# score in info and Markov labels, the learner acting at the trajectory level (its defaults)
FLUIDS_ID = "FLUIDS-v4"
TEST_EPISODES = 500
MUJOCO_TEST_EPISODES = 100  # 1,000-step episodes
OOD_EPISODES = 200
MUJOCO_OOD_EPISODES = 50
VALIDATION_EPISODES = 100
MUJOCO_VALIDATION_EPISODES = 20
# FLUIDS kwargs that change only what the learner sees, never the episode (the supervisor and the
# random policy do not read observations). The noise options are not among them: they draw from
# the env's generator, which the episode shares.
FLUIDS_OBSERVATION_KWARGS = (
    "obs_type",
    "obs_scale",
    "k_nearest",
    "birdseye_size",
    "birdseye_fov",
    "birdseye_frame",
    "lidar_rays",
    "lidar_range",
    "lidar_version",
)


@dataclass(frozen=True)
class OODSet:
    """An out-of-distribution test set: the task's env with `kwargs` changed.

    Attributes:
        name: short name, unique within the task (e.g. `"dense_traffic"`).
        kwargs: env kwargs that override the task's (JSON-friendly).
        description: what changes and from what, in words.
        episodes: how many episodes (seeds from the OOD block of the splits).
    """

    name: str
    kwargs: Mapping[str, Any]
    description: str
    episodes: int = OOD_EPISODES


@dataclass(frozen=True)
class Task:
    """One task of the suite.

    Attributes:
        name: short name (e.g. `"fluids"`), the scorecard's key.
        family: the task family (a folder of `fluids_bench/tasks/`).
        env_id: the Gymnasium id.
        env_kwargs: kwargs for `gym.make` (they set the action level and the observation).
        action_level: what the learner chooses, in words.
        observation: what the learner sees, in words.
        test_episodes: episodes of the test split.
        validation_episodes: episodes of the validation split.
        ood: the OOD test sets.
        observation_kwargs: env kwargs that change only the observation, never the episode: a
            policy trained with other values of them is evaluated on the same episodes with its
            own values (e.g. FLUIDS from bird's-eye images); the references keep the task's.
    """

    name: str
    family: str
    env_id: str
    env_kwargs: Mapping[str, Any]
    action_level: str
    observation: str
    test_episodes: int = TEST_EPISODES
    validation_episodes: int = VALIDATION_EPISODES
    ood: tuple[OODSet, ...] = ()
    observation_kwargs: tuple[str, ...] = ()

    def seeds(self, split: str) -> list[int]:
        """The seeds of `split`: `"validation"` or `"test"` (train: any seed below
        [`TRAIN_END`][fluids_bench.core.splits.TRAIN_END])."""
        counts = {"validation": self.validation_episodes, "test": self.test_episodes}
        if split not in counts:
            raise ValueError(f"split is {split!r}; allowed: {sorted(counts)}")
        return split_seeds(split, counts[split])

    def ood_seeds(self, name: str) -> list[int]:
        """The seeds of OOD set `name` (the first ones of the OOD block, as for every set)."""
        return split_seeds("ood", self.ood_set(name).episodes)

    def ood_set(self, name: str) -> OODSet:
        for ood in self.ood:
            if ood.name == name:
                return ood
        raise ValueError(
            f"task {self.name!r} has no OOD set {name!r}; allowed: {[o.name for o in self.ood]}"
        )

    def eval_sets(self, episodes: int | None = None) -> list[tuple[str, dict[str, Any], list[int]]]:
        """`(set name, env kwargs, seeds)` of every evaluation set: `"test"` first, then the
        OOD sets; `episodes` caps each set (a shortened evaluation)."""
        out = [("test", dict(self.env_kwargs), self.seeds("test"))]
        for ood in self.ood:
            out.append((ood.name, {**self.env_kwargs, **ood.kwargs}, self.ood_seeds(ood.name)))
        if episodes is not None:
            out = [(name, kwargs, seeds[:episodes]) for name, kwargs, seeds in out]
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "family": self.family,
            "env_id": self.env_id,
            "env_kwargs": dict(self.env_kwargs),
            "action_level": self.action_level,
            "observation": self.observation,
            "validation_episodes": self.validation_episodes,
            "test_episodes": self.test_episodes,
            "ood": [
                {
                    "name": o.name,
                    "kwargs": dict(o.kwargs),
                    "description": o.description,
                    "episodes": o.episodes,
                }  # fmt: skip
                for o in self.ood
            ],
        }


@dataclass(frozen=True)
class Suite:
    """The tasks of a benchmark, and how much of each set an evaluation runs.

    Attributes:
        tasks: the tasks, in report order.
        episodes: None for the full suite; N caps every evaluation set at its first N
            episodes (a shortened evaluation, labelled so in scorecards).
        version: [`SUITE_VERSION`][fluids_bench.benchmark.suite.SUITE_VERSION].
    """

    tasks: tuple[Task, ...]
    episodes: int | None = None
    version: str = field(default=SUITE_VERSION)

    @property
    def shortened(self) -> bool:
        """Whether this is less than the full suite (fewer episodes, fewer tasks, or a task
        with fewer sets: [`select`][fluids_bench.benchmark.suite.Suite.select]`(ood=False)`)."""
        full = {t.name: t for t in TASKS}
        return self.episodes is not None or {t.name: t for t in self.tasks} != full

    def task(self, name: str) -> Task:
        for task in self.tasks:
            if task.name == name:
                return task
        raise ValueError(f"unknown task {name!r}; allowed: {[t.name for t in self.tasks]}")

    def select(
        self, episodes: int | None = None, tasks: Sequence[str] | None = None, ood: bool = True
    ) -> Suite:
        """A shortened suite: the first `episodes` of each set, only `tasks` (names), and with
        `ood=False` the test split alone (the tasks' OOD sets dropped)."""
        if episodes is not None and (isinstance(episodes, bool) or not isinstance(episodes, int)
                                     or episodes < 1):  # fmt: skip
            raise ValueError(f"episodes is {episodes!r}; allowed: a positive integer or None")
        chosen = self.tasks if tasks is None else tuple(self.task(name) for name in tasks)
        if not chosen:
            raise ValueError("tasks is empty; allowed: one or more of " + ", ".join(TASK_NAMES))
        if not isinstance(ood, bool):
            raise ValueError(f"ood is {ood!r}; allowed: True or False")
        if not ood:
            chosen = tuple(replace(task, ood=()) for task in chosen)
        return replace(self, tasks=chosen, episodes=episodes)

    def to_dict(self) -> dict[str, Any]:
        return {
            "version": self.version,
            "fluids_id": FLUIDS_ID,
            "episodes": self.episodes,
            "shortened": self.shortened,
            "tasks": [t.to_dict() for t in self.tasks],
        }


# MuJoCo OOD sets: perturbations under which the shipped supervisor still does its task (it
# defines the score's 1). Measured (3 OOD seeds each): mass x1.1 and x0.9 keep Hopper, Walker2d
# and HalfCheetah near their nominal returns; friction x0.75 keeps HalfCheetah and Humanoid,
# but Hopper falls (~350 against ~3,160); any mass change (x0.9 or x1.1) makes the Humanoid
# supervisor fall in ~15 steps (return ~63, below random's ~126), so Humanoid has friction only.
HEAVY = OODSet("heavy", {"body_mass_scale": 1.1}, "every body's mass x1.1", MUJOCO_OOD_EPISODES)
LIGHT = OODSet("light", {"body_mass_scale": 0.9}, "every body's mass x0.9", MUJOCO_OOD_EPISODES)
SLIPPERY = OODSet(
    "slippery", {"friction_scale": 0.75}, "every geom's sliding friction x0.75", MUJOCO_OOD_EPISODES
)


def _mujoco(name: str, env_id: str, body: str, ood: tuple[OODSet, ...]) -> Task:
    return Task(
        name=name,
        family="locomotion",
        env_id=env_id,
        env_kwargs={},
        action_level="joint torques (Box, Gymnasium v5)",
        observation=f"Gymnasium v5 {body} state vector",
        test_episodes=MUJOCO_TEST_EPISODES,
        validation_episodes=MUJOCO_VALIDATION_EPISODES,
        ood=ood,
    )


TASKS: tuple[Task, ...] = (
    Task(
        name="fluids",
        family="fluids",
        env_id=FLUIDS_ID,
        env_kwargs={},
        action_level="the ego's next 5 waypoints in its own frame (Box(-1, 1, (10,)), times "
        "50 m); the velocity planner and the PID controller below follow them",
        observation="explicit: the ego's state and goal, the 8 nearest agents in its frame, its "
        "light (69 values scaled to [-1, 1])",
        ood=(
            OODSet("dense_traffic", {"num_cars": 6}, "6 background cars instead of 3"),
            OODSet(
                "t_junction",
                {"layout": "t_junction"},
                "the T-junction layout instead of the four-way intersection",
            ),
            OODSet(
                "fast_pedestrians",
                {"pedestrian_speed": 2.5},
                "pedestrians walk at up to 2.5 m/s instead of 1.4",
            ),
        ),
        observation_kwargs=FLUIDS_OBSERVATION_KWARGS,
    ),
    Task(
        name="gridworld",
        family="gridworld",
        env_id="GridWorld-v0",
        env_kwargs={},
        action_level="one of 5 moves (Discrete)",
        observation="the agent's cell (x, y)",
        ood=(
            OODSet("slippery", {"slip_probability": 0.32}, "slip probability 0.32 instead of 0.16"),
        ),
    ),
    Task(
        name="singulation",
        family="singulation",
        env_id="Singulation-v0",
        env_kwargs={},
        action_level="the arm's joint changes: base rotation and extension (Box 2, [-1, 1])",
        observation="the arm's pose and the 4 objects' positions and orientations (18 values)",
        ood=(
            OODSet("large_objects", {"object_size_scale": 1.25}, "objects 1.25x larger"),
            OODSet("high_friction", {"friction_scale": 2.0}, "friction x2"),
        ),
    ),
    Task(
        name="grasping",
        family="grasping",
        env_id="GraspingInClutter-v1",
        env_kwargs={},
        action_level="end-effector velocity and the gripper command (Box 3)",
        observation="the 6 boxes' poses (target first), the 3 joint angles, the gripper "
        "(22 values)",
        ood=(
            OODSet("large_obstacles", {"obstacle_size_scale": 1.25}, "obstacles 1.25x larger"),
            OODSet("high_friction", {"friction": 1.0}, "friction 1.0 instead of 0.5"),
        ),
    ),
    Task(
        name="track",
        family="track",
        env_id="DrivingTrack-v0",
        env_kwargs={},
        action_level="heading change: -15°, 0° or +15° (Discrete 3)",
        observation="HOG features of the car's view (20,736 values)",
        ood=(
            OODSet("fast", {"speed": 12.5}, "the car drives at 12.5 instead of 10"),
            OODSet("narrow", {"half_width": 10.0}, "road half-width 10 instead of 15"),
        ),
    ),
    _mujoco("hopper", "Hopper-IL-v0", "Hopper", (HEAVY, LIGHT)),
    _mujoco("walker2d", "Walker2d-IL-v0", "Walker2d", (HEAVY, LIGHT)),
    _mujoco("halfcheetah", "HalfCheetah-IL-v0", "HalfCheetah", (HEAVY, SLIPPERY)),
    _mujoco("humanoid", "Humanoid-IL-v0", "Humanoid", (SLIPPERY,)),
)
TASK_NAMES: tuple[str, ...] = tuple(t.name for t in TASKS)
SUITE = Suite(TASKS)
