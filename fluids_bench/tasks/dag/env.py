"""DAG-v0: the three-level decision DAG of the source's Theorem 1 (ch. 4, Fig. 4.1)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from fluids_bench.core.actions import check_action
from fluids_bench.core.snapshot import SnapshotMixin
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.core.validation import as_seed, check_choice, check_float, reject_unknown_kwargs
from fluids_bench.tasks.dag.draw import draw_dag
from fluids_bench.tasks.dag.model import DEPTH, L, transition
from fluids_bench.tasks.dag.supervisor import greedy_action

WHERE = "DAG-v0"


class DAGEnv(SnapshotMixin, gym.Env[np.ndarray, np.int64]):
    """
    ## Description

    The counter-example of the dissertation's Theorem 1: a robot descends a three-level
    directed acyclic graph from its root, choosing the left (L) or right (R) child at each node
    and collecting the reward on each branch. Only the root is stochastic: choosing L there
    reaches the right child with probability `mu`. A greedy supervisor labels every node (see
    `fluids_bench.tasks.dag.supervisor`; the DAG itself is `fluids_bench.tasks.dag.model`). With
    the constant policy class {L, R} (the `"constant"` policy of `fluids_bench.algos.policies`),
    off-policy learning (behaviour cloning) converges to the best constant policy L, while
    on-policy learning (DAgger, beta = 0) stays at R forever whenever its initial demonstrations
    happen to vote R, which happens with probability at least c e^{-m} for m initial
    demonstrations.

    ## Action Space

    `Discrete(2)`: 0 = L (left child), 1 = R (right child).

    ## Observation Space

    `Box(0, 3, (2,), float32)`: the node `(level, index)`, where `index` counts right moves so
    far (the node reached by L from `(l, i)` is `(l + 1, i)`, by R it is `(l + 1, i + 1)`).

    ## Rewards

    The reward of the branch taken: root (L 2, R 0); level 1: (1, 0) (L 2, R 0),
    (1, 1) (L 0, R 1); level 2: (2, 0) (L 2, R 0), (2, 1) (L 0, R 1), (2, 2) (L 0, R 1).
    Expected returns: supervisor 6 - 4 mu, constant L 6 - 6 mu, constant R 2.

    ## Starting State

    Always the root `(0, 0)` (the theorem's deterministic initial state).

    ## Episode End

    Termination after the third decision, on reaching level 3. The registration's
    `max_episode_steps` is 3, so truncation never comes first.

    ## Snapshots and labels

    `env.unwrapped.snapshot()` returns a picklable state (the node and `np_random`);
    `restore(snapshot)` on another env built with the same kwargs (reset with any seed)
    continues bit-identically. The label is a function of the node alone.

    ## Arguments

    The keyword arguments of `__init__`, each described in its `Args:`. Numbers may be Python
    or numpy scalars; a bad value raises `ValueError` naming it and what is allowed, an
    unknown argument `TypeError` (also a `ValueError`) listing the allowed ones.

    ## Version History

    * v0: Initial version.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 1}

    _snapshot_fields = ("_level", "_index", "_last_edge")

    @reject_unknown_kwargs
    def __init__(self, mu: float = 0.25, render_mode: str | None = None) -> None:
        """Build the DAG.

        Args:
            mu: Chance that L at the root slips to the right child.
            render_mode: `None` or `"rgb_array"` (the graph, the robot's node filled).
        """
        self.mu = check_float(WHERE, "mu", mu, 0.0, 1.0)
        self.render_mode = check_choice(WHERE, "render_mode", render_mode, [None, "rgb_array"])
        self.action_space = spaces.Discrete(2)
        self.observation_space = spaces.Box(0.0, float(DEPTH), (2,), np.float32)
        self._level = 0
        self._index = 0
        self._last_edge: tuple[int, int, int] | None = None  # drawn thick by render()

    def supervisor_action(self) -> np.int64:
        """The greedy supervisor's label at the current node (L at the leaves, unused)."""
        if self._level == DEPTH:
            return np.int64(L)
        return np.int64(greedy_action(self._level, self._index))

    def _observation(self) -> np.ndarray:
        return np.array([self._level, self._index], dtype=np.float32)

    def _info(self) -> dict[str, Any]:
        return {SUPERVISOR_ACTION_KEY: self.supervisor_action()}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        seed = as_seed(seed)  # np.int64(5) seeds as 5
        super().reset(seed=seed)
        self._level, self._index, self._last_edge = 0, 0, None
        return self._observation(), self._info()

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        move = check_action(WHERE, self.action_space, action)
        if self._level == DEPTH:
            raise RuntimeError(f"{WHERE}: step() after the episode ended; call reset()")
        # draw on every step, not only at the root, so the random stream does not depend on
        # the actions taken before
        slipped = self.np_random.random() < self.mu
        before = (self._level, self._index)
        self._level, self._index, reward = transition(self._level, self._index, move, slipped)
        self._last_edge = (*before, self._index - before[1])  # the move executed
        terminated = self._level == DEPTH
        return self._observation(), float(reward), terminated, False, self._info()

    def render(self) -> np.ndarray | None:
        """`render_mode="rgb_array"`: the graph with the robot's node filled and the edge it
        took drawn thick (`fluids_bench.tasks.dag.draw.draw_dag`); otherwise None."""
        if self.render_mode != "rgb_array":
            return None
        return draw_dag(self._level, self._index, self._last_edge)
