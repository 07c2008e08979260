"""The pure warehouse world: cells, actions, moves, targets and optimal distances.

Every environment of the package follows these rules, so the grid twin and the
physics-backed environment cannot drift apart. This module imports neither
gymnasium, pymunk nor pygame: only numpy, for the random generator type.
"""

from __future__ import annotations

from enum import IntEnum
from typing import NamedTuple

import numpy as np


class Action(IntEnum):
    """The four moves of the robot, numbered as in the action space."""

    LEFT = 0
    DOWN = 1
    RIGHT = 2
    UP = 3


class Cell(NamedTuple):
    """A cell of the floor; row 0 is the top row, column 0 the left column."""

    row: int
    col: int


#: The (row, column) change of each action, indexed by the action's value.
ACTION_DELTAS: tuple[tuple[int, int], ...] = (
    (0, -1),  # LEFT
    (1, 0),  # DOWN
    (0, 1),  # RIGHT
    (-1, 0),  # UP
)

#: Where the robot stands after every reset.
START_CELL = Cell(0, 0)

#: Reward for standing on the target; every other step earns nothing.
TARGET_REWARD = 1.0

MIN_ROWS = 2
MIN_COLS = 2


class WarehouseGrid:
    """An empty rectangular warehouse floor of ``rows`` x ``cols`` cells.

    The grid knows the rules and nothing about episodes: where a move leads,
    which cells may hold the target, how a target is drawn and how far any
    cell is from it.

    Raises:
        TypeError: if ``rows`` or ``cols`` is not an integer.
        ValueError: if the grid has fewer than 2 rows or 2 columns, which
            would leave no cell for the target outside row 0 and column 0.
    """

    __slots__ = ("cols", "rows", "target_cells")

    def __init__(self, rows: int, cols: int) -> None:
        self.rows = _checked_size("grid_rows", rows, MIN_ROWS)
        self.cols = _checked_size("grid_cols", cols, MIN_COLS)
        #: Every cell the target may be placed on, in row-major order: rows
        #: 1..R-1 and columns 1..C-1, so never the start cell's row or column.
        self.target_cells: tuple[Cell, ...] = tuple(
            Cell(r, c) for r in range(1, self.rows) for c in range(1, self.cols)
        )

    def __repr__(self) -> str:
        return f"WarehouseGrid(rows={self.rows}, cols={self.cols})"

    def contains(self, cell: tuple[int, int]) -> bool:
        """Whether ``cell`` lies on the floor."""
        row, col = cell
        return 0 <= row < self.rows and 0 <= col < self.cols

    def move(self, cell: tuple[int, int], action: int) -> Cell:
        """The cell reached from ``cell`` by ``action``.

        A move off the floor leaves the robot where it is.
        """
        d_row, d_col = ACTION_DELTAS[action]
        row, col = cell[0] + d_row, cell[1] + d_col
        if 0 <= row < self.rows and 0 <= col < self.cols:
            return Cell(row, col)
        return Cell(cell[0], cell[1])

    def sample_target(
        self, rng: np.random.Generator, exclude: tuple[int, int] | None = None
    ) -> Cell:
        """Draw the target uniformly from :attr:`target_cells` with one call to ``rng``.

        ``exclude`` (a robot's start cell, say) is left out of the draw; the
        default start (0, 0) is never a target cell, so excluding it changes nothing.
        """
        cells = self.target_cells
        if exclude is not None and exclude in cells:
            cells = tuple(cell for cell in cells if cell != exclude)
        return cells[int(rng.integers(len(cells)))]

    def optimal_steps(self, cell: tuple[int, int], target: tuple[int, int]) -> int:
        """The fewest actions that take the robot from ``cell`` to ``target``.

        On an empty floor this is the Manhattan distance.
        """
        return abs(cell[0] - target[0]) + abs(cell[1] - target[1])

    @staticmethod
    def outcome(cell: tuple[int, int], target: tuple[int, int]) -> tuple[float, bool]:
        """The reward and the ``terminated`` flag for a robot standing on ``cell``."""
        if cell[0] == target[0] and cell[1] == target[1]:
            return TARGET_REWARD, True
        return 0.0, False


def _checked_size(name: str, value: object, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    if value < minimum:
        raise ValueError(
            f"{name} must be at least {minimum}, got {value}: the target is placed in rows "
            "1..R-1 and columns 1..C-1, so a grid needs at least 2 rows and 2 columns"
        )
    return int(value)
