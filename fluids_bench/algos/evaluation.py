"""What an evaluation measures over seeded episodes: mean return and, where the env reports
them, success and collisions, each with its standard error.

Success is Gymnasium's convention, `info["is_success"]` on an episode's last step (an
episode that ends without it, e.g. truncated, counts as a failure). Collisions are the events
an env lists in `info["collisions"]` (FLUIDS: this step's collisions), summed per episode.
Envs that report neither get None for both.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fluids_bench.algos.dataset import Trajectory

SUCCESS_KEY = "is_success"
COLLISIONS_KEY = "collisions"


def standard_error(values: Sequence[float]) -> float | None:
    """Sample standard deviation over sqrt(n); None for fewer than two values."""
    if len(values) < 2:
        return None
    return float(np.std(values, ddof=1) / np.sqrt(len(values)))


@dataclass(frozen=True)
class Evaluation:
    episodes: int
    mean_return: float
    return_se: float | None
    success_rate: float | None
    success_se: float | None
    collisions: float | None  # mean collision events per episode

    def metrics(self) -> dict[str, float | None]:
        return {
            "return_se": self.return_se,
            "success_rate": self.success_rate,
            "success_se": self.success_se,
            "collisions": self.collisions,
        }


def _collision_count(trajectory: Trajectory) -> int:
    total = 0
    for info in trajectory.infos:
        events = info.get(COLLISIONS_KEY, ())
        total += int(events) if isinstance(events, int | np.integer) else len(events)
    return total


def evaluate_trajectories(
    trajectories: Sequence[Trajectory], reports_success: bool = False
) -> Evaluation:
    """Summarise evaluation episodes. Success is reported when one of them ends with
    `info["is_success"]`, or when `reports_success` says the env does (an earlier
    evaluation saw it: then a batch where every episode timed out scores 0, not None)."""
    reports_collisions = any(COLLISIONS_KEY in info for t in trajectories for info in t.infos)
    return summarise(
        [t.total_return for t in trajectories],
        [t.infos[-1] for t in trajectories],
        [_collision_count(t) for t in trajectories] if reports_collisions else None,
        reports_success,
    )


def summarise(
    returns: Sequence[float],
    last_infos: Sequence[dict],
    collisions: Sequence[int] | None,
    reports_success: bool = False,
) -> Evaluation:
    """`evaluate_trajectories` from each episode's return, last info and collision count
    (None where the env reports no collisions): what an evaluation keeps of its episodes."""
    reports_success = reports_success or any(SUCCESS_KEY in info for info in last_infos)
    success_rate = success_se = mean_collisions = None
    if reports_success:
        successes = [float(bool(info.get(SUCCESS_KEY, False))) for info in last_infos]
        success_rate, success_se = float(np.mean(successes)), standard_error(successes)
    if collisions is not None:
        mean_collisions = float(np.mean(collisions))
    return Evaluation(
        episodes=len(returns),
        mean_return=float(np.mean(returns)),
        return_se=standard_error(returns),
        success_rate=success_rate,
        success_se=success_se,
        collisions=mean_collisions,
    )
