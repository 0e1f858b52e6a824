"""The benchmark's metrics, as the field reports them.

- Per task: the **normalised score** `(R - R_random) / (R_supervisor - R_random)`, with the
  random policy's and the supervisor's mean returns measured on the same episodes (same env
  kwargs, same seeds) as the policy's; success rate; and, where the env reports it (FLUIDS-v4),
  the mean **driving score**. Each with a 95 % bootstrap interval over episodes.
- Across the suite: the **mean** and the **interquartile mean** (IQM) of the normalised scores
  with **stratified-bootstrap 95 % confidence intervals** (`rliable`, Agarwal et al. 2021:
  resampling within each task). rliable wants a `(runs, tasks)` matrix: a task's episodes are
  split into as many consecutive groups as the task with the fewest episodes has, and a group's
  mean is one "run" (the mean over runs is then the task's mean when the counts divide).
- The imitation-learning axis: the **label-efficiency curve**, score against supervisor labels
  used, and its **area** (the mean score over the label budget, trapezoidal).

rliable is the `eval` extra (`pip install "fluids-bench[eval]"`); it is imported when an
interval is computed.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

import numpy as np

BOOTSTRAP_REPS = 2000
BOOTSTRAP_SEED = 0  # intervals are reproducible: same scores, same interval
CONFIDENCE = 0.95


def _rliable():
    try:
        from rliable import library, metrics
    except ImportError as exc:
        raise ImportError(
            "confidence intervals need rliable: pip install 'fluids-bench[eval]' "
            f"(import failed: {exc})"
        ) from exc
    return library, metrics


@contextlib.contextmanager
def _global_numpy_seed(seed: int) -> Iterator[None]:
    """rliable 1.2 resamples with numpy's global generator (`np.random.choice`, whatever
    `random_state` says): seed it for the block and put its state back after."""
    state = np.random.get_state()  # noqa: NPY002  (rliable draws from it)
    np.random.seed(seed)  # noqa: NPY002
    try:
        yield
    finally:
        np.random.set_state(state)  # noqa: NPY002


def _conf_int(matrix: np.ndarray, func: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """rliable's stratified-bootstrap percentile interval of `func` on a `(runs, tasks)` matrix:
    `(2, k)`, low and high rows.

    Built as rliable's `get_interval_estimates` builds it, except that `StratifiedBootstrap`'s
    own constructor passes `random_state=` to arch's, which arch 8 no longer accepts (and arch 7
    does not import with pandas 3): the same object is set up here without it."""
    library, _ = _rliable()
    base = library.StratifiedBootstrap

    class Stratified(base):  # type: ignore[misc, valid-type]
        def __init__(self, scores: np.ndarray) -> None:
            super(base, self).__init__(scores)  # arch's IIDBootstrap, without random_state
            self._args_shape = scores.shape
            self._num_tasks = scores.shape[1]
            self._parameters = [self._num_tasks, False]
            self._task_bootstrap = False
            self._strata_indices = self._get_strata_indices()

    with _global_numpy_seed(BOOTSTRAP_SEED):
        bootstrap = Stratified(np.asarray(matrix, dtype=np.float64))
        ci = bootstrap.conf_int(func, reps=BOOTSTRAP_REPS, size=CONFIDENCE, method="percentile")
    return np.asarray(ci)


def _clean(value: float) -> float:
    """`value` rounded to 12 decimals, without a negative zero (-1e-17 prints as -0.000)."""
    return round(float(value), 12) + 0.0


def normalised_scores(
    returns: Sequence[float], random_returns: Sequence[float], supervisor_returns: Sequence[float]
) -> np.ndarray:
    """Per-episode normalised scores `(R_i - mean R_random) / (mean R_supervisor - mean R_random)`.

    Their mean is the task's normalised score: 0 is the random policy's, 1 the supervisor's.

    Args:
        returns: the policy's episode returns.
        random_returns: the random policy's returns on the same episodes.
        supervisor_returns: the supervisor's returns on the same episodes.

    Raises:
        ValueError: if the supervisor does not beat the random policy on these episodes (the
            score is undefined), or a list is empty.
    """
    if not len(returns) or not len(random_returns) or not len(supervisor_returns):
        raise ValueError("normalised_scores: every list of returns needs at least one episode")
    low, high = float(np.mean(random_returns)), float(np.mean(supervisor_returns))
    if not high > low:
        raise ValueError(
            f"normalised_scores: the supervisor's mean return {high:.6g} does not exceed the "
            f"random policy's {low:.6g} on these episodes; the normalised score is undefined"
        )
    return (np.asarray(returns, dtype=np.float64) - low) / (high - low)


def interval(values: Sequence[float]) -> tuple[float, float, float]:
    """The mean of `values` and its 95 % bootstrap interval (rliable, over episodes).

    Returns:
        `(mean, low, high)`; a single value gives a zero-width interval.
    """
    values = np.asarray(values, dtype=np.float64)
    if values.size == 0:
        raise ValueError("interval: no values")
    mean = float(values.mean())
    if values.size == 1:
        return mean, mean, mean
    ci = _conf_int(values.reshape(-1, 1), lambda scores: np.array([np.mean(scores)]))
    low, high = ci[:, 0]
    return _clean(mean), _clean(low), _clean(high)


def run_matrix(per_task: Mapping[str, Sequence[float]]) -> np.ndarray:
    """`(runs, tasks)` matrix for rliable: each task's episode scores split into `runs`
    consecutive groups (runs = the fewest episodes of any task), a cell is a group's mean."""
    if not per_task:
        raise ValueError("run_matrix: no tasks")
    runs = min(len(v) for v in per_task.values())
    if runs == 0:
        raise ValueError("run_matrix: a task has no episodes")
    columns = [
        [float(np.mean(g)) for g in np.array_split(np.asarray(v, dtype=np.float64), runs)]
        for v in per_task.values()
    ]
    return np.asarray(columns).T


def iqm(matrix: np.ndarray) -> float:
    """Interquartile mean of all cells (rliable's `aggregate_iqm`: the mean of the middle
    50 %, scipy's `trim_mean(·, 0.25)`)."""
    _, rl_metrics = _rliable()
    return float(rl_metrics.aggregate_iqm(np.asarray(matrix)))


def aggregate(per_task: Mapping[str, Sequence[float]]) -> dict[str, Any]:
    """Mean and IQM across tasks with stratified-bootstrap 95 % intervals.

    Args:
        per_task: task name -> that task's per-episode normalised scores.

    Returns:
        `{"mean": [point, low, high], "iqm": [point, low, high], "runs": R, "tasks": [...]}`.
    """
    _, rl_metrics = _rliable()
    matrix = run_matrix(per_task)

    def both(scores: np.ndarray) -> np.ndarray:
        return np.array([rl_metrics.aggregate_mean(scores), rl_metrics.aggregate_iqm(scores)])

    point, ci = both(matrix), _conf_int(matrix, both)
    return {
        "mean": [_clean(point[0]), _clean(ci[0, 0]), _clean(ci[1, 0])],
        "iqm": [_clean(point[1]), _clean(ci[0, 1]), _clean(ci[1, 1])],
        "runs": int(matrix.shape[0]),
        "tasks": list(per_task),
    }


def label_efficiency(
    labels: Sequence[float], scores: Sequence[float], budget: float | None = None
) -> dict[str, Any]:
    """The label-efficiency curve (score against supervisor labels used) and its area.

    The area is the trapezoidal integral of the curve from its first point to `budget`
    (default: its last point) divided by that label range: the mean score over the budget,
    in the score's units (1 = the supervisor's level from the first label on). Past its last
    point the curve is held at its last score.

    Args:
        labels: supervisor labels used at each point (increasing after sorting; ties averaged
            is not done: give distinct counts).
        scores: the score at each point.
        budget: the label count the area runs to (>= the first point).

    Returns:
        `{"labels": [...], "scores": [...], "area": float, "budget": float}`.
    """
    x = np.asarray(labels, dtype=np.float64)
    y = np.asarray(scores, dtype=np.float64)
    if x.shape != y.shape or x.ndim != 1 or x.size == 0:
        raise ValueError("label_efficiency: labels and scores need the same, non-zero length")
    if len(np.unique(x)) != len(x):
        raise ValueError(f"label_efficiency: labels {x.tolist()} repeat; allowed: distinct counts")
    order = np.argsort(x)
    x, y = x[order], y[order]
    end = float(x[-1]) if budget is None else float(budget)
    if end < x[0]:
        raise ValueError(f"label_efficiency: budget {budget} is below the first point {x[0]}")
    if end == x[0]:
        area = float(y[0])
    else:
        xs, ys = x[x <= end], y[x <= end]
        if xs[-1] < end:  # hold the last score, or interpolate to the budget inside the curve
            ys = np.append(ys, np.interp(end, x, y))
            xs = np.append(xs, end)
        area = float(np.sum((xs[1:] - xs[:-1]) * (ys[1:] + ys[:-1]) / 2.0) / (end - xs[0]))
    return {"labels": x.tolist(), "scores": y.tolist(), "area": area, "budget": end}
