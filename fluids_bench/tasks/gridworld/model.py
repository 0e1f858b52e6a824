"""The gridworld of the source's ch. 3 as plain data: world generation, the slip dynamics, their
explicit transition table and a picture. No gymnasium here (the env is a thin adapter).

States are flat cell indices `s = x * size + y`; the robot's cell is `(x, y)`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse

LEFT, RIGHT, FORWARD, BACKWARD, STAY = range(5)
ACTION_NAMES = ("left", "right", "forward", "backward", "stay")
# (dx, dy) of each action, in action order
MOVES = np.array([(-1, 0), (1, 0), (0, 1), (0, -1), (0, 0)], dtype=np.int64)

FREE, PENALTY, GOAL = 0, 1, 2
# RGB colours of free, penalty and goal cells and of the robot, for rgb_array rendering
COLOURS = np.array([(235, 235, 235), (200, 40, 40), (40, 170, 60)], dtype=np.uint8)
ROBOT_COLOUR = np.array((40, 80, 220), dtype=np.uint8)
CELL_PIXELS = 16
ROBOT_MARGIN = 3  # pixels of the cell's colour around the robot


@dataclass(frozen=True, eq=False)
class GridWorld:
    """One generated world: `cells[x, y]` in {FREE, PENALTY, GOAL}, the deterministic move
    table `next_state[s, a]`, the reward `state_rewards[s]` paid on entering `s`, and the
    cells an episode may start from."""

    size: int
    slip_probability: float
    cells: np.ndarray
    next_state: np.ndarray
    state_rewards: np.ndarray
    start_states: np.ndarray

    @classmethod
    def generate(
        cls,
        size: int,
        penalty_fraction: float,
        slip_probability: float,
        goal_reward: float,
        penalty_reward: float,
        world_seed: int,
    ) -> GridWorld:
        """One goal, then `penalty_fraction` of the cells as penalties, drawn from
        `world_seed` (arguments already validated by the caller)."""
        cells = generate_cells(size, penalty_fraction, np.random.default_rng(world_seed))
        flat = cells.reshape(-1)
        rewards = np.where(
            flat == GOAL, goal_reward, np.where(flat == PENALTY, penalty_reward, 0.0)
        )
        return cls(
            size=size,
            slip_probability=slip_probability,
            cells=cells,
            next_state=next_state_table(size),
            state_rewards=rewards,
            start_states=np.flatnonzero(flat == FREE),
        )

    def transition_matrix(self) -> sparse.csr_array:
        """The explicit table `P` of the slip dynamics: row `s * 5 + a` is `P(. | s, a)`.

        Sparse (at most five reachable cells per row): a dense table of a 100 x 100 grid
        would take 4 GB.
        """
        n_states, n_actions = self.next_state.shape
        p_other = self.slip_probability / (n_actions - 1)
        rows, cols, weights = [], [], []
        for intended in range(n_actions):
            for executed in range(n_actions):
                rows.append(np.arange(n_states) * n_actions + intended)
                cols.append(self.next_state[:, executed])
                weight = 1.0 - self.slip_probability if executed == intended else p_other
                weights.append(np.full(n_states, weight))
        shape = (n_states * n_actions, n_states)
        # duplicate (row, col) entries (moves into the border) are summed
        return sparse.csr_array(
            (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=shape
        )

    def start(self, rng: np.random.Generator) -> int:
        """A start cell drawn uniformly from the free cells."""
        return int(rng.choice(self.start_states))

    def step(self, state: int, action: int, rng: np.random.Generator) -> tuple[int, float]:
        """Execute `action` from `state`; with probability `slip_probability` one of the
        other moves, uniformly, instead. Returns the next state and the reward paid there."""
        executed = action
        if rng.random() < self.slip_probability:
            # one of the other moves, uniformly: shift by 1..n-1 modulo n
            shift = int(rng.integers(1, len(MOVES)))
            executed = (executed + shift) % len(MOVES)
        state = int(self.next_state[state, executed])
        return state, float(self.state_rewards[state])

    def cell(self, state: int) -> tuple[int, int]:
        return divmod(state, self.size)

    def draw(self, state: int) -> np.ndarray:
        """RGB picture, `CELL_PIXELS` per cell, forward (y + 1) pointing up. The robot is a
        square inset in its cell, so the cell's own colour (the goal's green, a penalty's red)
        still shows around it."""
        x, y = self.cell(state)
        # rows of the image are y from top to bottom, so forward (y + 1) points up
        image = np.flipud(COLOURS[self.cells].transpose(1, 0, 2))
        image = np.repeat(np.repeat(image, CELL_PIXELS, axis=0), CELL_PIXELS, axis=1)
        row, col = (self.size - 1 - y) * CELL_PIXELS, x * CELL_PIXELS
        m = ROBOT_MARGIN
        image[row + m : row + CELL_PIXELS - m, col + m : col + CELL_PIXELS - m] = ROBOT_COLOUR
        return image


def generate_cells(size: int, penalty_fraction: float, rng: np.random.Generator) -> np.ndarray:
    """`cells[x, y]` in {FREE, PENALTY, GOAL}: one goal, then penalties among the rest."""
    n = size * size
    order = rng.permutation(n)
    cells = np.full(n, FREE, dtype=np.int64)
    cells[order[0]] = GOAL
    n_penalties = min(int(round(penalty_fraction * n)), n - 2)  # keep a start cell
    cells[order[1 : 1 + n_penalties]] = PENALTY
    return cells.reshape(size, size)


def next_state_table(size: int) -> np.ndarray:
    """`next_state[s, a]`: the cell reached by executing move `a` exactly from `s` (a move
    into the border stays)."""
    xs, ys = np.divmod(np.arange(size * size), size)
    nx = np.clip(xs[:, None] + MOVES[None, :, 0], 0, size - 1)
    ny = np.clip(ys[:, None] + MOVES[None, :, 1], 0, size - 1)
    return nx * size + ny
