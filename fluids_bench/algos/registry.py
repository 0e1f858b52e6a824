"""Every algorithm by name, with its config class and preset defaults (used by the CLI)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from fluids_bench.algos import bc, dagger, dart, noise, ogd, shiv
from fluids_bench.algos.config import RunConfig
from fluids_bench.algos.harness import ProgressCallback
from fluids_bench.algos.results import RunResult


@dataclass(frozen=True)
class Algorithm:
    config_class: type[RunConfig]
    run: Callable[..., RunResult]
    summary: str
    presets: Mapping[str, Any] = field(default_factory=dict)


ALGORITHMS: dict[str, Algorithm] = {
    "bc": Algorithm(bc.BCConfig, bc.run, "Behavior Cloning (off-policy)"),
    "dagger": Algorithm(
        dagger.DAggerConfig, dagger.run, "DAgger (on-policy, refit every iteration)"
    ),
    "dagger_b": Algorithm(
        dagger.DAggerConfig,
        dagger.run,
        "DAgger-B (refit only at --retrain-at iterations, or every --retrain-every)",
        {"retrain_at": (2, 8)},
    ),
    "noise": Algorithm(noise.NoiseConfig, noise.run, "isotropic noise injection (off-policy)"),
    "dart": Algorithm(dart.DARTConfig, dart.run, "DART (noise fit to the learner's errors)"),
    "shiv": Algorithm(shiv.SHIVConfig, shiv.run, "SHIV (on-policy, queries only risky states)"),
    "ogd": Algorithm(ogd.OGDConfig, ogd.run, "online gradient on-policy (linear policy)"),
}


def get_algorithm(name: str) -> Algorithm:
    if name not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {name!r}; allowed: {sorted(ALGORITHMS)}")
    return ALGORITHMS[name]


def run_algorithm(
    name: str, progress: ProgressCallback | None = None, **settings: Any
) -> RunResult:
    """Build `name`'s config from its presets and `settings`, then run it."""
    algorithm = get_algorithm(name)
    config = algorithm.config_class(**{**algorithm.presets, **settings})
    return algorithm.run(config, progress)
