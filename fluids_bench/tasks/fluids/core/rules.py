"""What an agent did in a step and what it earns for it, on B rows: the one place these rules live.

A row is one subject of one step: a world's ego (`FluidsEnv` is B = 1, the vector env one row per
world) or one live agent of the multi-agent env (one row per agent, its own subject). Every
function takes arrays with a leading axis of B, or one row without that axis as Python scalars
(what `FluidsEnv` passes: its world's own arrays, whose entries the rules read as Python
numbers, so that its step allocates no batch and pays no numpy call per rule), and does the
same float operations in the same order on each row, so a world's reward has the same bits
whichever face computes it.

The step's verdict (`judge`, `judge_worlds`):

* `ego_hit`: the subject was in a new collision (`involved`, `ego_hits`);
* `failed_by`: a new collision that fails the episode: the subject's with `done_when="ego"`,
  any in the world with `done_when="all"`;
* `broken`: how many rules that fail `is_success` the subject broke in this step (a red light
  with `obey_lights`, a failure to yield with `yield_to_pedestrians`: `violations` after the
  fault tracker recorded the step less before);
* `gained`: the metres of route it covered (`route_progress` now less at the last step);
* `terminated`: it arrived (every car did, with `"all"`) or a collision failed it, or it broke
  a rule with `end_on_violation`.

Then `succeeded` (`is_success`: arrived, never in a collision, no rule broken) and
`step_rewards` (every `reward_version`, see `FluidsEnv`'s Rewards), and `timed_out` (the
driving score's timeout).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

COLLISION_PENALTY = 1.0  # subtracted from a car's reward in a step where it is in a collision
# reward_version=1 (the v2 ids and later): a reward that agrees with is_success
REWARD_VERSIONS = (0, 1)
SUCCESS_BONUS = 1.0  # paid on the step that ends an episode (an agent's) with is_success
VIOLATION_PENALTY = 1.0  # a red light run or a failure to yield, once each, when it happens


class Rules(NamedTuple):
    """The options the step rules read (the env's checked arguments of the same names). Every
    function's `rules` is one of these or any object with these fields as attributes (a
    `FluidsEnv` passes itself, the vector env its `FluidsConfig`: no tuple to build per step)."""

    done_when: str = "ego"
    end_on_violation: bool = False
    obey_lights: bool = False
    yield_to_pedestrians: bool = False
    reward_version: int = 0
    failure_penalty: float = 1.0


@dataclass(slots=True)
class Judged:
    """One step's verdict on B rows (entries of rows that did not step are unused)."""

    terminated: np.ndarray  # bool (B,)
    ego_hit: np.ndarray  # bool (B,): the subject was in a new collision
    failed_by: np.ndarray  # bool (B,): a new collision failed the episode
    gained: np.ndarray  # (B,) metres of route the subject covered in the step
    broken: np.ndarray  # int (B,) rules the subject broke in the step


def involved(events: Sequence, agent: int) -> bool:
    """Whether `agent` is one of the two parties of any of the collisions `events`."""
    return any(e.a == agent or e.b == agent for e in events)


def agent_events(events: Sequence, agent: int) -> list:
    """The collisions of `events` that `agent` is one of the two parties of."""
    return [e for e in events if agent in (e.a, e.b)]


def route_length(path_len, last_s):
    """The length (m) of a subject's route counted from its progress at the last step
    (`last_s`; `path_len`: its path's length): what the progress reward divides by, set at
    reset and again when the subject's route changes (scalars or arrays alike)."""
    return path_len - last_s


def ego_hits(events: Sequence[Sequence], hit: np.ndarray, agent: int = 0) -> np.ndarray:
    """(B,) bool: whether `agent` is in one of each world's new collisions `events[b]`
    (`hit`: the worlds that have any; the others are not searched)."""
    out = np.zeros(len(hit), dtype=np.bool_)
    for b in hit.nonzero()[0].tolist():
        out[b] = involved(events[b], agent)
    return out


def _select(condition, yes, no):
    """`np.where(condition, yes, no)` on rows; `yes if condition else no` on one row."""
    if isinstance(condition, np.ndarray):
        return np.where(condition, yes, no)
    return yes if condition else no


def _not(flags):
    """`~flags` on rows (bool arrays); `not flags` on one row (a Python bool)."""
    return ~flags if isinstance(flags, np.ndarray) else not flags


def ego_of(agents: np.ndarray):
    """Agent 0's entries of (B, N) rows, (B,); or its entry of one world's (N,), as a Python
    number."""
    return agents[:, 0] if agents.ndim > 1 else agents.item(0)


def _every_car(flags: np.ndarray, is_car: np.ndarray):
    """Whether every car's flag is set, in each of (B, N) rows (B,), or in one world's (N,)
    (a Python bool)."""
    if flags.ndim > 1:
        return flags[:, is_car].all(axis=1)
    return bool(flags[is_car].all())


def _any_car(flags: np.ndarray, is_car: np.ndarray):
    """Whether any car's flag is set, as `_every_car`."""
    if flags.ndim > 1:
        return flags[:, is_car].any(axis=1)
    return bool(flags[is_car].any())


def violations(rules: Rules, ran_red: np.ndarray, failed_to_yield: np.ndarray) -> np.ndarray:
    """(B,) int64: how many of the rules that fail `is_success` each subject has broken so far
    (`ran_red`, `failed_to_yield`: its fault tracker's flags, (B,) bool; Python bools for
    one row give an int)."""
    return int(rules.obey_lights) * ran_red + int(rules.yield_to_pedestrians) * failed_to_yield


def route_progress(
    reached: np.ndarray, path_len: np.ndarray, s: np.ndarray, offset: np.ndarray
) -> np.ndarray:
    """(B,) metres of its route each subject has covered (past the path's end once arrived)."""
    return _select(reached, path_len + offset, s + offset)


def arrivals(rules: Rules, reached: np.ndarray, is_car: np.ndarray):
    """Of B worlds' agents' `reached` flags ((B, N), or one world's (N,)): whether the cars the
    episode is about arrived, (B,): the ego (agent 0) with `done_when="ego"`, every car with
    `"all"`."""
    if rules.done_when == "ego":
        return ego_of(reached)
    return _every_car(reached, is_car)


def subjects(
    rules: Rules, reached: np.ndarray, collided: np.ndarray, is_car: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """`arrivals`, and whether none of those cars was ever in a collision (`collided`, shaped
    as `reached`), (B,) each."""
    if rules.done_when == "ego":
        return ego_of(reached), _not(ego_of(collided))
    return _every_car(reached, is_car), _not(_any_car(collided, is_car))


def judge(
    rules: Rules,
    arrived: np.ndarray,
    ego_hit: np.ndarray,
    any_hit: np.ndarray,
    s_now: np.ndarray,
    last_s: np.ndarray,
    broken: np.ndarray,
) -> Judged:
    """The verdict of a step on B rows: `arrived` as `subjects` gives it, `ego_hit` /
    `any_hit` the subject's / the world's new collisions, `s_now` and `last_s` its route
    progress after and before the step, `broken` the rules it broke in the step."""
    failed_by = any_hit if rules.done_when == "all" else ego_hit
    terminated = arrived | failed_by
    if rules.end_on_violation:  # is_success can no longer hold
        terminated = terminated | (broken > 0)
    return Judged(terminated, ego_hit, failed_by, s_now - last_s, broken)


def judge_worlds(
    rules: Rules,
    reached: np.ndarray,
    is_car: np.ndarray,
    ego_hit: np.ndarray,
    any_hit: np.ndarray,
    broken: np.ndarray,
    last_s: np.ndarray,
    paths: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> tuple[Judged, np.ndarray]:
    """`judge` of B worlds' egos from their agents' rows ((B, N), or (N,) for one world):
    `reached` and `paths`: `(s, offset, path_len)`; `last_s` the egos'
    progress at the last step. Returns the verdict and the egos' progress now (the face keeps
    it as the next step's `last_s`)."""
    s, offset, path_len = paths
    s_now = route_progress(ego_of(reached), ego_of(path_len), ego_of(s), ego_of(offset))
    arrived = arrivals(rules, reached, is_car)
    return judge(rules, arrived, ego_hit, any_hit, s_now, last_s, broken), s_now


def succeeded(
    rules: Rules,
    arrived: np.ndarray,
    clean: np.ndarray,
    ran_red: np.ndarray | None = None,
    failed_to_yield: np.ndarray | None = None,
) -> np.ndarray:
    """(B,) `is_success` of each row (meaningful where it terminated): the subjects arrived
    and were never in a collision (`subjects`), and with `obey_lights` the ego never ran a
    red light, with `yield_to_pedestrians` it never failed to yield (its fault tracker's
    flags, (B,))."""
    success = arrived & clean
    if rules.obey_lights:
        success &= _not(ran_red)
    if rules.yield_to_pedestrians:
        success &= _not(failed_to_yield)
    return success


def step_rewards(
    rules: Rules, judged: Judged, success: np.ndarray, route_length: np.ndarray
) -> np.ndarray:
    """(B,) float64: each row's reward for the step (see `FluidsEnv`'s Rewards).

    `reward_version=0`: the metres of route gained over the route's length from the start (an
    episode that reaches the goal earns 1 in total), minus `COLLISION_PENALTY` in a step where
    the subject is in a collision. `reward_version=1`: that progress, minus `failure_penalty`
    times `COLLISION_PENALTY` in a step with a collision that fails the episode and times
    `VIOLATION_PENALTY` for each rule the step broke that fails `is_success`, plus
    `SUCCESS_BONUS` on the step that ends the episode with `is_success` (`success`)."""
    if rules.reward_version == 0:
        penalty = _select(judged.ego_hit, COLLISION_PENALTY, 0.0)
        return judged.gained / route_length - penalty
    weight = rules.failure_penalty
    penalty = _select(judged.failed_by, weight * COLLISION_PENALTY, 0.0)
    bonus = _select(judged.terminated & success, SUCCESS_BONUS, 0.0)
    broken = weight * VIOLATION_PENALTY * judged.broken
    return judged.gained / route_length - penalty - broken + bonus


def timed_out(terminated: bool, time_limit: int, steps: int) -> bool:
    """The driving score's timeout: the episode did not terminate and its world reached
    `time_limit` steps (0: no limit)."""
    return not terminated and 0 < time_limit == steps
