"""GridWorld-v0: the stochastic gridworld of the source's on- vs off-policy experiment (ch. 3)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from fluids_bench.core.actions import check_action
from fluids_bench.core.snapshot import SnapshotMixin
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY
from fluids_bench.core.validation import (
    REWARD_LIMIT,
    as_seed,
    check_choice,
    check_float,
    check_int,
    reject_unknown_kwargs,
)
from fluids_bench.tasks.gridworld.model import MOVES, GridWorld
from fluids_bench.tasks.gridworld.supervisor import value_iteration

WHERE = "GridWorld-v0"


class GridWorldEnv(SnapshotMixin, gym.Env[np.ndarray, np.int64]):
    """
    ## Description

    A robot on a square grid must reach the single goal cell and stay there, while avoiding the
    penalty cells that cover a fixed fraction of the grid. Its moves slip: with probability
    `slip_probability` the executed move is replaced by one of the *other* four moves (stay
    included), drawn uniformly. This is the world of the dissertation's ch. 3 experiment
    ("Off-Policy vs. On-Policy"), used to show that on-policy sampling wins over off-policy when
    the policy class is not expressive, and that the gap closes when it is.

    Each `world_seed` generates a new world (goal and penalty cells), fixed for the lifetime of
    the env; `reset(seed=...)` seeds only the episode (start cell and slips). Algorithms can
    therefore keep one world across iterations while varying episode seeds, and a study over
    many worlds varies `world_seed`.

    The supervisor (`supervisor_action()` and `info["supervisor_action"]`) is the optimal
    stationary policy of the discounted problem, solved exactly by value iteration on the
    explicit transition table (`transitions`), see `fluids_bench.tasks.gridworld.supervisor`.
    Every `discount` in (0, 1) is solved: where value iteration needs more than 3,000 sweeps
    (discounts above about 0.99) it finishes with exact policy iteration, which takes a few
    seconds on the largest grid even at 0.9999.
    The world itself (generation, slips, the table, the picture) is
    `fluids_bench.tasks.gridworld.model.GridWorld` (`env.world`); `cells`, `next_state`,
    `transitions` and `state_rewards` are its arrays.

    ## Action Space

    `Discrete(5)`:

    - 0: left (x - 1)
    - 1: right (x + 1)
    - 2: forward (y + 1)
    - 3: backward (y - 1)
    - 4: stay

    A move into the border leaves the robot where it is.

    ## Observation Space

    `Box(0, size - 1, (2,), float32)`: the robot's cell `(x, y)`, integers stored as floats.

    ## Rewards

    Every step pays the reward of the cell the robot enters: `goal_reward` (+10) at the goal,
    `penalty_reward` (-10) on a penalty cell, 0 elsewhere. Staying on the goal keeps paying.

    ## Starting State

    A cell drawn uniformly from the cells that are neither a penalty nor the goal.

    ## Episode End

    No termination: the robot should reach the goal and stay. Truncation after 30 steps
    (`max_episode_steps` of the registration, the source's T = 30).

    ## Snapshots and labels

    `env.unwrapped.snapshot()` returns a picklable state (the agent's cell and `np_random`);
    `restore(snapshot)` on another env built with the same kwargs (reset with any seed)
    continues bit-identically. The label is a function of the cell alone.

    ## Arguments

    The keyword arguments of `__init__`, each described in its `Args:`. Numbers may be Python
    or numpy scalars; a bad value raises `ValueError` naming it and what is allowed, an
    unknown argument `TypeError` (also a `ValueError`) listing the allowed ones.

    ```python
    >>> import gymnasium as gym, fluids_bench
    >>> env = gym.make("GridWorld-v0", world_seed=3)
    >>> obs, info = env.reset(seed=0)
    >>> action = info["supervisor_action"]
    ```

    ## Version History

    * v0: Initial version.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 4}

    # the agent's cell (the world is generated from world_seed at construction)
    _snapshot_fields = ("_state",)

    @reject_unknown_kwargs
    def __init__(
        self,
        size: int = 15,
        penalty_fraction: float = 0.08,
        slip_probability: float = 0.16,
        goal_reward: float = 10.0,
        penalty_reward: float = -10.0,
        discount: float = 0.95,
        world_seed: int = 0,
        render_mode: str | None = None,
    ) -> None:
        """Build the gridworld (its cells are drawn from `world_seed`).

        Args:
            size: Side of the square grid, in cells.
            penalty_fraction: Share of the cells that are penalty cells.
            slip_probability: Chance that a move is replaced by another one.
            goal_reward: Reward per step on the goal.
            penalty_reward: Reward per step on a penalty cell.
            discount: Discount of the supervisor's value iteration.
            world_seed: Seed of the world's layout (goal and penalty cells).
            render_mode: `None` or `"rgb_array"`.
        """
        self.size = check_int(WHERE, "size", size, 2, 100)
        self.penalty_fraction = check_float(WHERE, "penalty_fraction", penalty_fraction, 0.0, 0.5)
        self.slip_probability = check_float(WHERE, "slip_probability", slip_probability, 0.0, 1.0)
        self.goal_reward = check_float(
            WHERE, "goal_reward", goal_reward, 0.0, REWARD_LIMIT, lo_open=True
        )
        self.penalty_reward = check_float(
            WHERE, "penalty_reward", penalty_reward, -REWARD_LIMIT, 0.0
        )
        self.discount = check_float(
            WHERE, "discount", discount, 0.0, 1.0, lo_open=True, hi_open=True
        )
        self.world_seed = check_int(WHERE, "world_seed", world_seed, 0)
        self.render_mode = check_choice(WHERE, "render_mode", render_mode, [None, "rgb_array"])

        self.action_space = spaces.Discrete(len(MOVES))
        self.observation_space = spaces.Box(0.0, float(self.size - 1), (2,), np.float32)

        self.world = GridWorld.generate(
            self.size,
            self.penalty_fraction,
            self.slip_probability,
            self.goal_reward,
            self.penalty_reward,
            self.world_seed,
        )
        self.cells, self.next_state = self.world.cells, self.world.next_state
        self.state_rewards = self.world.state_rewards
        self.transitions = self.world.transition_matrix()
        solution = value_iteration(self.transitions, self.state_rewards, self.discount)
        self.supervisor_policy = solution.policy
        self.supervisor_values = solution.values
        self._state = int(self.world.start_states[0])

    def _observation(self) -> np.ndarray:
        return np.array(self.world.cell(self._state), dtype=np.float32)

    def _info(self) -> dict[str, Any]:
        return {SUPERVISOR_ACTION_KEY: self.supervisor_action()}

    # -- the Gymnasium API ------------------------------------------------------------------

    def supervisor_action(self) -> np.int64:
        """The value-iteration supervisor's move in the current cell."""
        return np.int64(self.supervisor_policy[self._state])

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        seed = as_seed(seed)  # np.int64(5) seeds as 5
        super().reset(seed=seed)
        self._state = self.world.start(self.np_random)
        return self._observation(), self._info()

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        executed = check_action(WHERE, self.action_space, action)
        self._state, reward = self.world.step(self._state, executed, self.np_random)
        return self._observation(), reward, False, False, self._info()

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        return self.world.draw(self._state)
