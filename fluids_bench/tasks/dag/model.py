"""The decision DAG of the source's Theorem 1 (ch. 4, Fig. 4.1) as plain data. No gymnasium.

Nodes are `(level, index)` with levels 0..3 and `index <= level`; from `(l, i)` action L
leads to `(l + 1, i)` and action R to `(l + 1, i + 1)`, so middle nodes are shared (a DAG,
not a tree). Every edge carries a reward. Only the root is stochastic: L there slips to the
right child with probability mu.
"""

from __future__ import annotations

L, R = 0, 1
ACTION_NAMES = ("L", "R")
DEPTH = 3  # levels below the root: an episode is exactly three decisions

# EDGE_REWARDS[level][index] = (reward of the L branch, reward of the R branch)
EDGE_REWARDS: tuple[tuple[tuple[float, float], ...], ...] = (
    ((2.0, 0.0),),
    ((2.0, 0.0), (0.0, 1.0)),
    ((2.0, 0.0), (0.0, 1.0), (0.0, 1.0)),
)


def transition(level: int, index: int, move: int, slipped: bool) -> tuple[int, int, float]:
    """`(level, index, reward)` after taking `move` at node `(level, index)`; `slipped`
    (drawn with probability mu) turns L at the root into R."""
    if level == 0 and move == L and slipped:
        move = R
    return level + 1, index + move, EDGE_REWARDS[level][index][move]
