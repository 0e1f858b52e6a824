"""The greedy supervisor of the decision DAG of the source's Theorem 1 (ch. 4, Fig. 4.1).

The DAG itself is `fluids_bench.tasks.dag.model`. The supervisor is greedy: at each node it
takes the branch with the larger immediate reward (the source's "acts greedily according to the
given rewards"). The model's edge rewards make the supervisor's labels

    root: L      (1, 0): L   (1, 1): R      (2, 0): L   (2, 1): R   (2, 2): R

so that, as in the proof, a supervisor demonstration reads L L L when the root move succeeds and
L R R when it slips to the right child (probability mu). The constant policy L then has
expected 0/1 loss 2 mu and R has loss 1, so L is the best policy of the class {L, R} for
mu < 1/2, while R is what on-policy learning keeps if its first majority vote says R.
"""

from __future__ import annotations

from fluids_bench.tasks.dag.model import ACTION_NAMES, DEPTH, EDGE_REWARDS, L, R


def greedy_action(level: int, index: int) -> int:
    """The supervisor's label at node `(level, index)`: the branch with the larger reward."""
    reward_left, reward_right = EDGE_REWARDS[level][index]
    return L if reward_left > reward_right else R


def expected_return(mu: float, policy: str) -> float:
    """Exact expected return from the root of `"supervisor"` or a constant policy `"L"`/`"R"`.

    Used to state the reference numbers of the DAG example (normalisation, plots).
    """
    if policy not in ("supervisor", "L", "R"):
        raise ValueError(f"expected_return: policy {policy!r}; allowed: supervisor, L, R")

    def walk(level: int, index: int) -> float:
        if level == DEPTH:
            return 0.0
        action = (
            greedy_action(level, index) if policy == "supervisor" else ACTION_NAMES.index(policy)
        )
        outcomes = [(1.0, action)]
        if level == 0 and action == L:
            outcomes = [(1.0 - mu, L), (mu, R)]  # the root's slip
        return sum(
            p * (EDGE_REWARDS[level][index][move] + walk(level + 1, index + move))
            for p, move in outcomes
        )

    return float(walk(0, 0))
