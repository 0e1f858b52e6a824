"""The gridworld supervisor: exact discounted value iteration on the explicit transition table.

The observation of `fluids_bench.tasks.gridworld.env.GridWorldEnv` is the cell `(x, y)` with no
clock, so a learner can only represent stationary policies. The supervisor is therefore the
optimal *stationary* policy of the infinite-horizon discounted problem (ch. 3, "We use Value
Iteration to compute an optimal supervisor"), iterated until the Bellman residual is below
`tol`, rather than the time-dependent optimum of the 30-step finite horizon.

Ties between actions (exact symmetries of open ground) go to the lowest action index, so the
labels are a deterministic function of the world.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse import linalg as _sparse_linalg  # noqa: F401  (sparse.linalg)

# Q-values this close to the best count as ties (floating-point noise of the iteration).
TIE_TOLERANCE = 1e-9


@dataclass(frozen=True)
class ValueIterationResult:
    """Optimal values `V[s]`, action values `Q[s, a]` and the greedy policy `policy[s]`."""

    values: np.ndarray
    q_values: np.ndarray
    policy: np.ndarray
    iterations: int


def value_iteration(
    transitions: sparse.sparray | np.ndarray,
    rewards: np.ndarray,
    discount: float,
    tol: float = 1e-10,
    max_iterations: int = 3_000,
) -> ValueIterationResult:
    """Solve `V(s) = max_a sum_s' P(s'|s,a) (r(s') + discount V(s'))`.

    `transitions` is the table `P` with one row per state–action pair: row `s * A + a`
    holds `P(. | s, a)` (a scipy sparse matrix or a dense array of shape `(S * A, S)`).
    `rewards[s']` is paid on entering `s'`. Stops when the largest change of `V` in one
    sweep is below `tol`.

    Value iteration contracts by `discount` per sweep, so near 1 it needs ~`ln(tol) /
    ln(discount)` sweeps (25,000 at 0.999, 250,000 at 0.9999: minutes on a large grid). After
    `max_iterations` sweeps it finishes with exact policy iteration started from the greedy
    policy so far (sparse linear solves; a handful of improvements), so every discount in
    (0, 1) is solved; a discount that converges within the sweeps gets exactly value iteration.
    """
    if not 0.0 < discount < 1.0:
        raise ValueError(f"value_iteration: field 'discount' is {discount!r}; allowed: (0, 1)")
    n_states = len(rewards)
    n_rows, n_cols = transitions.shape
    if n_cols != n_states or n_rows % n_states:
        raise ValueError(
            f"value_iteration: transitions of shape {transitions.shape} for {n_states} states; "
            "allowed: (S * A, S)"
        )
    n_actions = n_rows // n_states
    values = np.zeros(n_states)
    sweeps, delta = 0, np.inf
    while delta >= tol:
        if sweeps == max_iterations:
            return _policy_iteration(transitions, rewards, discount, values, sweeps)
        q_values = (transitions @ (rewards + discount * values)).reshape(n_states, n_actions)
        new_values = q_values.max(axis=1)
        delta = float(np.max(np.abs(new_values - values)))
        values = new_values
        sweeps += 1
    q_values = (transitions @ (rewards + discount * values)).reshape(n_states, n_actions)
    return ValueIterationResult(values, q_values, greedy_policy(q_values), sweeps)


def _policy_iteration(
    transitions: sparse.sparray | np.ndarray,
    rewards: np.ndarray,
    discount: float,
    values: np.ndarray,
    sweeps: int,
    max_improvements: int = 1_000,
) -> ValueIterationResult:
    """Exact policy iteration from the greedy policy of `values`: evaluate the policy by
    solving `(I - discount P_pi) V = P_pi r`, improve greedily (keeping an action within
    `TIE_TOLERANCE` of the best, so ties cannot cycle), stop when the policy is stable."""
    n_states = len(rewards)
    table = sparse.csr_array(transitions)
    n_actions = table.shape[0] // n_states
    rows = np.arange(n_states) * n_actions
    eye = sparse.identity(n_states, format="csc")
    q_values = (table @ (rewards + discount * values)).reshape(n_states, n_actions)
    policy = greedy_policy(q_values)
    for improvement in range(1, max_improvements + 1):
        chosen = table[rows + policy]
        values = sparse.linalg.spsolve(sparse.csc_array(eye - discount * chosen), chosen @ rewards)
        q_values = (table @ (rewards + discount * values)).reshape(n_states, n_actions)
        best = q_values.max(axis=1)
        keep = q_values[np.arange(n_states), policy] >= best - TIE_TOLERANCE
        improved = np.where(keep, policy, greedy_policy(q_values))
        if np.array_equal(improved, policy):
            return ValueIterationResult(
                values, q_values, greedy_policy(q_values), sweeps + improvement
            )
        policy = improved
    raise RuntimeError(f"policy iteration did not converge in {max_improvements} improvements")


def greedy_policy(q_values: np.ndarray) -> np.ndarray:
    """The best action per state; near-ties go to the lowest action index."""
    best = q_values.max(axis=1, keepdims=True)
    return np.argmax(q_values >= best - TIE_TOLERANCE, axis=1).astype(np.int64)
