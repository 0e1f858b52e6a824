"""The settings every algorithm shares; each algorithm's config extends `RunConfig`."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import Any

from fluids_bench.algos.learners.protocol import describe_source, is_learner
from fluids_bench.algos.learners.sklearn import PolicySpec
from fluids_bench.core.parallel import BACKENDS  # where a run's rollouts execute
from fluids_bench.core.validation import check_choice, check_float, check_int, fail

# settings of how a run executes, not of what it computes: left out of to_dict (and so of the
# records), since the result is the same bit for bit whatever they are
EXECUTION_FIELDS = ("workers", "backend", "address", "checkpoint")


@dataclass(frozen=True, kw_only=True)
class RunConfig:
    """Environment, learner, data budget, evaluation and seed of one run.

    `iterations` counts data-collection rounds after any initial demonstrations, each round
    collecting `demos_per_iteration` rollouts. `samples_per_demo` is the ch. 3 protocol:
    keep that many state–label pairs of each rollout for training (None: all of them). The
    learner is evaluated at the iterations in `eval_at` (None: every `eval_every`-th,
    counting the initial demonstrations as iteration 0) and always at the last one, over
    `eval_episodes` seeded episodes; the supervisor is rolled out with the same seeds once, to
    normalise: `(R - return_floor) / (R_supervisor - return_floor)` (1.0 = the supervisor).

    `policy` is a scikit-learn family (a `PolicySpec`), or any learner with
    `fit(observations, labels)` and `predict(observations)`, or a zero-argument factory of
    one (a class, a function), which each run calls once for a fresh learner
    (`fluids_bench.algos.learners`). A learner given itself is refit in place: a second
    run with it continues from its state if it warm-starts.

    Execution (the result does not depend on it): the rollouts of an iteration and the
    evaluation episodes run on `workers` processes (`backend="process"`; 1: in this
    process) or as Ray tasks, at most `workers` at a time (`backend="ray"`: on the Ray
    instance already initialised, else the cluster at `address`, else a local one with
    `workers` CPUs); the learner is fitted in this process. Every rollout's seed is drawn in
    order from the run's seed, so any `workers` and either backend give the same records.
    `checkpoint`: a folder where every finished rollout, evaluation and record is kept; a run
    of the same config with the same folder reuses them and continues where the last one
    stopped (`fluids_bench.algos.checkpoint`).
    """

    env_id: str = "GridWorld-v0"
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    # a scikit-learn family, or any learner (fit/predict) or a zero-argument factory of one
    policy: Any = field(default_factory=PolicySpec)
    iterations: int = 10
    demos_per_iteration: int = 1
    samples_per_demo: int | None = 50
    eval_episodes: int = 10
    eval_every: int = 1
    eval_at: tuple[int, ...] | None = None
    max_steps: int | None = None
    return_floor: float = 0.0
    seed: int = 0
    workers: int = 1
    backend: str = "process"
    address: str | None = None
    checkpoint: str | os.PathLike[str] | None = None

    def __post_init__(self) -> None:
        where = type(self).__name__
        if not isinstance(self.env_id, str) or not self.env_id:
            fail(where, "env_id", self.env_id, "a registered Gymnasium id")
        if not isinstance(self.env_kwargs, Mapping):
            fail(where, "env_kwargs", self.env_kwargs, "a mapping of keyword arguments")
        if not (
            isinstance(self.policy, PolicySpec) or is_learner(self.policy) or callable(self.policy)
        ):
            fail(
                where,
                "policy",
                self.policy,
                "a PolicySpec, a learner (fit/predict) or a zero-argument factory of one",
            )
        check_int(where, "iterations", self.iterations, 1)
        check_int(where, "demos_per_iteration", self.demos_per_iteration, 1)
        if self.samples_per_demo is not None:
            check_int(where, "samples_per_demo", self.samples_per_demo, 1)
        check_int(where, "eval_episodes", self.eval_episodes, 1)
        check_int(where, "eval_every", self.eval_every, 1)
        if self.eval_at is not None:
            check_iterations(where, "eval_at", self.eval_at, first=0, last=self.iterations)
        if self.max_steps is not None:
            check_int(where, "max_steps", self.max_steps, 1)
        check_float(where, "return_floor", self.return_floor)
        check_int(where, "seed", self.seed, 0, 2**32 - 1)
        check_int(where, "workers", self.workers, 1)
        check_choice(where, "backend", self.backend, BACKENDS)
        if self.address is not None:
            if not isinstance(self.address, str) or not self.address:
                fail(where, "address", self.address, "a Ray address such as 'auto' or None")
            if self.backend != "ray":
                fail(where, "address", self.address, "None unless backend is 'ray'")
        if self.checkpoint is not None and not isinstance(self.checkpoint, str | os.PathLike):
            fail(where, "checkpoint", self.checkpoint, "a folder path or None")

    def evaluates_at(self, iteration: int) -> bool:
        """Whether the learner is evaluated after `iteration`."""
        if iteration == self.iterations:
            return True
        if self.eval_at is not None:
            return iteration in self.eval_at
        return iteration % self.eval_every == 0

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly copy (tuples become lists when serialised); a learner or factory is
        recorded by name (`{"learner": "module:factory"}`, or its own `describe()`)."""
        if not isinstance(self.policy, PolicySpec):
            data = asdict(replace(self, policy=PolicySpec()))
            data["env_kwargs"] = dict(self.env_kwargs)
            data["policy"] = {"learner": describe_source(self.policy)}
            for name in EXECUTION_FIELDS:
                del data[name]
            return data
        data = asdict(self)
        for name in EXECUTION_FIELDS:
            del data[name]
        data["env_kwargs"] = dict(self.env_kwargs)
        if self.policy.standardize:  # the default is left out: records stay as they were
            del data["policy"]["standardize"]
        return data


def check_iterations(
    where: str, name: str, values: tuple[int, ...], first: int = 1, last: int | None = None
) -> tuple[int, ...]:
    """A schedule of iteration numbers: a tuple of distinct ints in `[first, last]`
    (`last=None`: no upper bound), increasing."""
    top = math.inf if last is None else last
    if not isinstance(values, tuple) or any(
        isinstance(v, bool) or not isinstance(v, int) or not first <= v <= top for v in values
    ):
        within = f">= {first}" if last is None else f"in [{first}, {last}] (the iterations run)"
        fail(where, name, values, f"a tuple of iteration numbers {within}")
    if list(values) != sorted(set(values)):
        fail(where, name, values, "distinct iteration numbers in increasing order")
    return values
