"""`FluidsConfig`: every option of a FLUIDS env, in one frozen dataclass shared by all faces.

The scalar env (`FluidsEnv`, the `FLUIDS-v*` ids), the vector env (which builds one
`FluidsEnv` per world) and the PettingZoo env (`FluidsParallelEnv`) take the same options
as keyword arguments; a `Face` says which of them one env takes, with which defaults, and
gives that env its signature and its `Args:` documentation. Versions are presets of these
options in `fluids_bench.registration`.

A field's description is its entry in `FluidsConfig`'s `Attributes:` section (what the API
pages render), read once by `field_docs`; the docs' argument tables show the same text.
"""

from __future__ import annotations

import dataclasses
import inspect
import textwrap
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cache
from types import MappingProxyType
from typing import Any

from fluids_bench.core.docstrings import section_entries
from fluids_bench.core.validation import (
    check_bool,
    check_choice,
    check_float,
    check_int,
    fail,
    finite_float,
    unknown_arguments,
)
from fluids_bench.tasks.fluids.core.actions import ACTION_SCALES
from fluids_bench.tasks.fluids.observations import ObservationConfig
from fluids_bench.tasks.fluids.sim.config import LAYOUTS
from fluids_bench.tasks.fluids.supervisor.stack import LEVELS

MAX_CARS = 64  # every car of a scene, controlled ones included
DONE_WHEN = ("ego", "all")
TRAJECTORY_PLANNERS = ("bezier", "ompl")
# The cars' true mass, kg. The supervisor's controller assumes 1500 kg (the default car's,
# scenario.ASSUMED_MASS); outside 1/3x to 10/3x of that its accelerations are off by more than
# the PID corrects: at 1 kg it oscillates into 26 collisions in 37 steps, at 1e5 kg no car
# arrives in an episode. The sensitivity sweep's values (750 to 3000 kg) lie inside.
CAR_MASS_RANGE = (500.0, 5000.0)
CAR_MASS_ALLOWED = (
    f"a finite number of kg in [{CAR_MASS_RANGE[0]}, {CAR_MASS_RANGE[1]}] (the supervisor's "
    "controller assumes 1500 kg; much lighter or heavier cars make it collide or never arrive)"
)
# the groups of options, in the order the fields are declared
GROUPS = ("scene", "actions", "sensors", "supervisor", "rules", "reward")
SINGLE, MULTI = "FluidsEnv", "FluidsParallelEnv"


def _option(default: Any, group: str, only: str | None = None) -> Any:
    """A field of `FluidsConfig`: its default, its group and, if only one face takes it,
    that face's name."""
    return field(default=default, metadata={"group": group, "only": only})


@dataclass(frozen=True)
class FluidsConfig:
    """Every option of a FLUIDS env, checked (numpy scalars become Python numbers, a list of
    observation types a tuple). Build it from an env's keyword arguments with
    `Face.config` (errors then name the env), or directly (errors name `FluidsConfig`); one
    check needs the compiled layout and is made when an env is built: the cars must fit the
    layout's entry slots.

    Fields come in groups (`group`): the scene, the learner's actions, the sensors, the
    supervisor, the episode's rules and the reward. `FluidsEnv` takes every field but
    `controlled_cars`, `max_cycles` and `black_death` (it controls one car, the ego, and
    `TimeLimit` truncates); the multi-agent env takes every field but `pedestrian_speed`,
    `light_cycle_scale`, `done_when`, `obey_lights`, `end_on_violation` and `time_limit`.

    Attributes:
        layout: The road network: `"four_way"` (default), `"t_junction"` or `"roundabout"`.
        lanes: Lanes per direction, 1 or 2 (the four-way and the T-junction).
        lights: Traffic and crosswalk lights on (default) or off.
        controlled_cars: Learner-controlled cars: the multi-agent env's agents `car_0 …
            car_{n-1}` (default 4 there); `FluidsEnv` controls one, the ego.
        num_cars: Supervised background cars besides the controlled ones (default 3 in
            `FluidsEnv`, 0 in the multi-agent env). All cars together fit the layout's entry
            slots: 16 on the one-lane four-way, 32 on the two-lane one, 12 / 24 on the
            T-junction, 16 on the roundabout (more raise `ValueError` naming the maximum).
        num_pedestrians: Supervised pedestrians, at most the layout's walk slots (default 2).
        car_mass: The cars' true mass in kg (default 1500). The supervisor's controller
            assumes 1500 kg, and far from it (1 kg, 1e5 kg) it oscillates into collisions or
            never arrives, so the range stops at 1/3x and 10/3x of it.
        pedestrian_speed: Pedestrians' top walking speed in m/s (default 1.4).
        light_cycle_scale: Every traffic and crosswalk light phase (and offset) lasts this many
            times its layout's duration (default 1: the layout's timing).
        dt: Seconds per step (default 0.1).
        action_level: The level the learner acts at and the supervisor labels at:
            `"behavior"`, `"trajectory"`, `"velocity"` or `"control"` (default); the
            supervisor fills the levels below it (see the env card's Action Space).
        action_scale: `"physical"` (default) or `"normalized"` (the v2 and later ids): every
            Box level is `[-1, 1]`, labels in the same units (see Action Space).
        waypoints: Path points `K` of a trajectory-level action (default 5).
        waypoint_spacing: Metres between those points along the path (default 2).
        obs_type: `"explicit"` (default), `"birdseye"`, `"qlidar"` or a list of them (a
            `Dict` space keyed by type); see the env card's Observation Space.
        obs_noise: Variance of the zero-mean Gaussian noise added to the explicit observation
            (default 0).
        k_nearest: Other agents listed in the explicit observation (default 8).
        birdseye_size: Side of the bird's-eye image in pixels (default 84).
        birdseye_fov: Side in metres of the square the bird's-eye image shows in the ego
            frames (default 40).
        birdseye_frame: `"ego"` (default: a north-up square centred on the ego),
            `"ego_rotated"` (turned so that the ego faces up) or `"global"` (the whole
            layout; `birdseye_fov` unused).
        pixel_noise: λ_p, variance of the zero-mean Gaussian noise added to every pixel value
            of the bird's-eye image, clipped to [0, 255] (default 0).
        lidar_rays: m, the quasi-LIDAR's rays, ray `k` at angle `2πk/m` from the heading
            (default 64).
        lidar_range: Metres a quasi-LIDAR ray reaches (default 30).
        lidar_noise: λ_l, variance of the Gaussian noise on a ray's distance, angle and
            velocity (default 0).
        lidar_dropout: ε, the probability that a ray reads as empty (default 0).
        lidar_version: 0 (default) or 1 (the v1 and later ids): rays also stop at the stop
            lines of red and yellow lights and at occupied crosswalks, and a goal row is added
            (see Observation Space).
        obs_scale: `"physical"` (default) or `"normalized"` (the v2 and later ids): the
            explicit and quasi-LIDAR observations become flat float32 vectors in `[-1, 1]`.
        planner_period: Steps between velocity-planner runs (default 5: 0.5 s; 1 in the v4
            ids); the plan, and the velocity-level label, is held in between.
        trajectory_planner: `"bezier"` (default: de Casteljau curves through lane-end
            waypoints) or `"ompl"` (every route's junction part planned as OMPL Dubins
            curves).
        defensive: Background agents treat the controlled cars as drivers that may brake as
            hard as they can at any time: they only take a target speed from which, holding
            it until their next plan and braking then, they stop short of wherever a
            controlled car can stop (default False; True in the v1 and later ids). A
            supervised car then never runs into one unless it cuts in inside its stopping
            distance. Where a controlled car has the right of way (it entered the junction
            first, or goes straight or turns right while they turn left across it), they also
            give way to it driving on: they turn or enter only through a gap it cannot close
            and do not enter a crossing they would have to stop in.
        done_when: `"ego"` (default): the episode ends when the ego arrives or is in a
            collision; `"all"` (the sensitivity ids): when every car has arrived or on any
            collision (see Episode End).
        obey_lights: Success also requires that the ego never entered its junction against a
            red light (`info["ego_ran_red_light"]`; default False, True in the v1 and later
            ids).
        yield_to_pedestrians: A pedestrian on a crosswalk has the right of way: supervised
            cars wait before a crosswalk with a pedestrian on it (unless they can no longer
            stop), and supervised walkers wait at the kerb while a car is committed to their
            crosswalk (default False; True in the v1 and later ids). In `FluidsEnv` success
            also requires that the ego never drove onto an occupied crosswalk it could have
            stopped for (`info["ego_failed_to_yield"]`); the multi-agent env's success does
            not depend on it.
        end_on_violation: Also end the episode in the step the ego breaks a rule that fails
            `is_success` (a red light with `obey_lights`, a failure to yield with
            `yield_to_pedestrians`; default False; see Episode End).
        max_cycles: Steps before every live agent of the multi-agent env is truncated
            (default 400 = 40 s).
        black_death: Keep the multi-agent env's finished agents in the episode, with zero
            observations and rewards, until every agent has finished (default False; see
            Episode End).
        reward_version: 0 (default): the route's progress, minus 1 in a step with a
            collision; 1 (the v2 and later ids): a reward that agrees with `is_success`,
            where every way to fail costs and success pays (see Rewards).
        failure_penalty: The weight of reward version 1's failure terms (collision, red light,
            failure to yield; default 1, 3 in the v3 and v4 ids); with `reward_version=0`
            only 1.
        driving_score: Report the CARLA-style driving score in the info of the step that ends
            an episode (each agent's, in the multi-agent env, where a truncation at
            `max_cycles` is its timeout): `info["driving_score"]` and
            `info["route_completion"]` in [0, 1] and `info["infractions"]` (counts by name);
            default False, True in the v4 ids. The rule is
            `fluids_bench.tasks.fluids.driving_score`.
        time_limit: The step at which an unfinished episode is scored as a timeout (0, the
            default: never). The v4 ids set it to their `max_episode_steps` (600): give
            both when you change one, so that the score lands on `TimeLimit`'s truncating
            step.
    """

    # scene
    layout: str = _option("four_way", "scene")
    lanes: int = _option(1, "scene")
    lights: bool = _option(True, "scene")
    controlled_cars: int = _option(1, "scene", only=MULTI)
    num_cars: int = _option(3, "scene")
    num_pedestrians: int = _option(2, "scene")
    car_mass: float = _option(1500.0, "scene")
    pedestrian_speed: float = _option(1.4, "scene", only=SINGLE)
    light_cycle_scale: float = _option(1.0, "scene", only=SINGLE)
    dt: float = _option(0.1, "scene")
    # the learner's actions
    action_level: str = _option("control", "actions")
    action_scale: str = _option("physical", "actions")
    waypoints: int = _option(5, "actions")
    waypoint_spacing: float = _option(2.0, "actions")
    # sensors: exactly ObservationConfig's fields
    obs_type: str | tuple[str, ...] = _option("explicit", "sensors")
    obs_noise: float = _option(0.0, "sensors")
    k_nearest: int = _option(8, "sensors")
    birdseye_size: int = _option(84, "sensors")
    birdseye_fov: float = _option(40.0, "sensors")
    birdseye_frame: str = _option("ego", "sensors")
    pixel_noise: float = _option(0.0, "sensors")
    lidar_rays: int = _option(64, "sensors")
    lidar_range: float = _option(30.0, "sensors")
    lidar_noise: float = _option(0.0, "sensors")
    lidar_dropout: float = _option(0.0, "sensors")
    lidar_version: int = _option(0, "sensors")
    obs_scale: str = _option("physical", "sensors")
    # the supervisor
    planner_period: int = _option(5, "supervisor")
    trajectory_planner: str = _option("bezier", "supervisor")
    defensive: bool = _option(False, "supervisor")
    # the episode's rules
    done_when: str = _option("ego", "rules", only=SINGLE)
    obey_lights: bool = _option(False, "rules", only=SINGLE)
    yield_to_pedestrians: bool = _option(False, "rules")
    end_on_violation: bool = _option(False, "rules", only=SINGLE)
    max_cycles: int = _option(400, "rules", only=MULTI)
    black_death: bool = _option(False, "rules", only=MULTI)
    # the reward
    reward_version: int = _option(0, "reward")
    failure_penalty: float = _option(1.0, "reward")
    driving_score: bool = _option(False, "reward")
    time_limit: int = _option(0, "reward", only=SINGLE)

    def __post_init__(self) -> None:
        checked = _checked(type(self).__name__, dataclasses.asdict(self))
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    def group(self, name: str) -> dict[str, Any]:
        """The fields of group `name` (one of `GROUPS`) and their values."""
        check_choice(type(self).__name__, "group", name, GROUPS)
        return {
            f.name: getattr(self, f.name)
            for f in dataclasses.fields(self)
            if f.metadata["group"] == name
        }

    def observation(self) -> ObservationConfig:
        """The sensors' config (the `"sensors"` group)."""
        return ObservationConfig(**self.group("sensors"))


def _checked(where: str, values: dict[str, Any]) -> dict[str, Any]:
    """`values` (every field of `FluidsConfig`) checked, with errors naming `where`; numpy
    scalars as Python numbers. The order is that of the envs' checks before the config."""
    v = dict(values)
    v["max_cycles"] = check_int(where, "max_cycles", v["max_cycles"], 1, 10**9)
    v["controlled_cars"] = check_int(where, "controlled_cars", v["controlled_cars"], 1, MAX_CARS)
    check_choice(where, "done_when", v["done_when"], DONE_WHEN)
    for name in ("defensive", "obey_lights", "yield_to_pedestrians", "black_death"):
        v[name] = check_bool(where, name, v[name])
    check_choice(where, "action_scale", v["action_scale"], ACTION_SCALES)
    v["reward_version"] = check_int(where, "reward_version", v["reward_version"], 0, 1)
    v["end_on_violation"] = check_bool(where, "end_on_violation", v["end_on_violation"])
    v["failure_penalty"] = check_failure_penalty(where, v["failure_penalty"], v["reward_version"])
    v["driving_score"] = check_bool(where, "driving_score", v["driving_score"])
    v["time_limit"] = check_int(where, "time_limit", v["time_limit"], 0, 10**9)
    check_choice(where, "action_level", v["action_level"], LEVELS)
    check_choice(where, "layout", v["layout"], LAYOUTS)
    check_choice(where, "trajectory_planner", v["trajectory_planner"], TRAJECTORY_PLANNERS)
    v["lanes"] = check_int(where, "lanes", v["lanes"], 1, 2)
    v["lights"] = check_bool(where, "lights", v["lights"])
    v["num_cars"] = check_int(where, "num_cars", v["num_cars"], 0, MAX_CARS - v["controlled_cars"])
    v["num_pedestrians"] = check_int(where, "num_pedestrians", v["num_pedestrians"], 0, 32)
    v["dt"] = check_float(where, "dt", v["dt"], 0.01, 0.5)
    v["pedestrian_speed"] = check_float(where, "pedestrian_speed", v["pedestrian_speed"], 0.1, 5.0)
    v["light_cycle_scale"] = check_float(
        where, "light_cycle_scale", v["light_cycle_scale"], 0.25, 4.0
    )
    lo, hi = CAR_MASS_RANGE
    mass = finite_float(v["car_mass"])
    if mass is None or not lo <= mass <= hi:
        fail(where, "car_mass", v["car_mass"], CAR_MASS_ALLOWED)
    v["car_mass"] = mass
    v["planner_period"] = check_int(where, "planner_period", v["planner_period"], 1, 50)
    v["waypoints"] = check_int(where, "waypoints", v["waypoints"], 1, 50)
    v["waypoint_spacing"] = check_float(where, "waypoint_spacing", v["waypoint_spacing"], 0.5, 20.0)
    sensors = [f.name for f in dataclasses.fields(ObservationConfig)]
    options = {name: v[name] for name in sensors if name != "obs_type"}
    observation = ObservationConfig.from_kwargs(where, v["obs_type"], options)
    v.update({name: getattr(observation, name) for name in sensors})
    return v


def check_failure_penalty(where: str, value: Any, reward_version: int) -> float:
    """`failure_penalty`: a finite weight in [0, 100] of reward version 1's failure terms
    (collision, red light, failure to yield); with reward version 0 only its default, 1."""
    penalty = check_float(where, "failure_penalty", value, 0.0, 100.0)
    if reward_version == 0 and penalty != 1.0:
        fail(where, "failure_penalty", value, "1.0 with reward_version=0 (it weights reward "
             "version 1's failure terms); pass reward_version=1 to change it")  # fmt: skip
    return penalty


@cache
def field_docs() -> dict[str, str]:
    """Each field's description: its entry in `FluidsConfig`'s `Attributes:` section."""
    docs = section_entries(FluidsConfig.__doc__, "Attributes")
    names = [f.name for f in dataclasses.fields(FluidsConfig)]
    missing, extra = set(names) - set(docs), set(docs) - set(names)
    if missing or extra:
        raise RuntimeError(
            f"FluidsConfig's Attributes section: undocumented fields {sorted(missing)}, "
            f"entries for no field {sorted(extra)}"
        )
    return {name: docs[name] for name in names}


@dataclass(frozen=True)
class Face:
    """One FLUIDS env's view of `FluidsConfig`: the env's name (in errors), its own defaults
    where they differ from the config's, and its arguments that are not options. It takes
    every field whose `only` is None or its name."""

    name: str
    defaults: Mapping[str, Any] = field(default_factory=dict)
    own: tuple[str, ...] = ("render_mode",)  # the env's arguments that are not options

    def __post_init__(self) -> None:
        object.__setattr__(self, "defaults", MappingProxyType(dict(self.defaults)))

    @property
    def options(self) -> tuple[str, ...]:
        """The fields this env takes as keyword arguments, in the config's order."""
        return tuple(
            f.name
            for f in dataclasses.fields(FluidsConfig)
            if f.metadata["only"] in (None, self.name)
        )

    def default(self, name: str) -> Any:
        """The default of option `name` in this env."""
        if name in self.defaults:
            return self.defaults[name]
        return FluidsConfig.__dataclass_fields__[name].default

    def check_names(self, kwargs: Mapping[str, Any]) -> None:
        """Raise `UnknownArgumentError` for a name in `kwargs` that is neither an option of
        this env nor one of its `own` arguments, listing the allowed ones."""
        unknown = set(kwargs) - set(self.options) - set(self.own)
        if unknown:
            raise unknown_arguments(self.name, unknown, [*self.options, *self.own])

    def config(self, kwargs: Mapping[str, Any]) -> FluidsConfig:
        """The config of this env's options `kwargs`: an unknown name raises
        `UnknownArgumentError` listing the allowed ones, a bad value `ValueError` naming the
        argument and this env."""
        self.check_names(kwargs)
        values = {f.name: f.default for f in dataclasses.fields(FluidsConfig)}
        values.update({name: self.default(name) for name in self.options})
        values.update(kwargs)
        return FluidsConfig(**_checked(self.name, values))

    def attributes(self, config: FluidsConfig) -> dict[str, Any]:
        """The options this env takes and their values in `config` (the env's attributes)."""
        return {name: getattr(config, name) for name in self.options}

    def document(self, init: Callable[..., None]) -> Callable[..., None]:
        """Decorate the env's `__init__(self, *, own..., **options)`: its signature lists
        every option (keyword-only, with this env's defaults) before its own arguments, and
        its docstring's `Args:` section (the docstring's last) gains every option's
        description from `field_docs`."""
        own = [p for p in inspect.signature(init).parameters.values() if p.kind == p.KEYWORD_ONLY]
        hints = {f.name: f.type for f in dataclasses.fields(FluidsConfig)}
        params = [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)]
        params += [
            inspect.Parameter(
                name,
                inspect.Parameter.KEYWORD_ONLY,
                default=self.default(name),
                annotation=hints[name],
            )
            for name in self.options
        ]
        init.__signature__ = inspect.Signature([*params, *own])
        docs = field_docs()
        entries = [
            textwrap.fill(
                f"{name}: {docs[name]}",
                width=92,
                initial_indent=" " * 4,
                subsequent_indent=" " * 8,
            )
            for name in self.options
        ]
        init.__doc__ = inspect.cleandoc(init.__doc__ or "") + "\n" + "\n".join(entries)
        return init


SINGLE_AGENT = Face(SINGLE)
MULTI_AGENT = Face(MULTI, defaults={"controlled_cars": 4, "num_cars": 0})
