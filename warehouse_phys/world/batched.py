"""The rules of one warehouse floor as arrays, for many robots at once.

:class:`BatchedRules` turns a :class:`~warehouse_phys.world.grid.WarehouseGrid` into
look-up tables, so that moving thousands of robots, placing their packages and
measuring their distances are a few array operations each. Every table is
derived from the grid's own rules (its ``move``, its target cells, its
breadth-first distances): the grid stays the single source of truth. Like
:mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.

Cells are numbered row by row, ``index = row * cols + col``.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.world.grid import ACTION_DELTAS, TARGET_REWARD, WarehouseGrid

#: Largest table of distances kept whole [entries]: 16 MiB of int64. Larger floors
#: compute distances as they go (cached per package on floors with shelves).
DISTANCE_TABLE_ENTRIES = 2**21


class BatchedRules:
    """Look-up tables for the rules of ``grid``.

    Attributes:
        grid: The floor the tables describe.
        moves: ``(cells * 4,)`` int64: ``moves[cell * 4 + action]`` is the cell a
            robot on ``cell`` reaches with ``action`` (itself when the move is
            refused), exactly ``grid.move``. Shelf cells, where no robot ever
            stands, map to themselves.
        rows, cols: ``(cells,)`` int64: the row and the column of every cell.
        start: The start cell's index.
        targets: ``(targets,)`` int64: ``grid.target_cells`` as indices, in order.
    """

    def __init__(self, grid: WarehouseGrid) -> None:
        self.grid = grid
        n_rows, n_cols = grid.rows, grid.cols
        n_cells = n_rows * n_cols
        index = np.arange(n_cells, dtype=np.int64)
        self.rows, self.cols = index // n_cols, index % n_cols
        moves = np.repeat(index, 4).reshape(n_cells, 4)
        free, reachable = grid.free_mask.reshape(-1), grid.reachable_mask.reshape(-1)
        for action, (d_row, d_col) in enumerate(ACTION_DELTAS):  # grid.move, a whole floor at once
            to_row, to_col = self.rows + d_row, self.cols + d_col
            to = to_row * n_cols + to_col
            inside = (to_row >= 0) & (to_row < n_rows) & (to_col >= 0) & (to_col < n_cols)
            allowed = inside & reachable  # robots stand on reachable cells only
            allowed[allowed] = free[to[allowed]]
            moves[allowed, action] = to[allowed]
        self.moves = moves.reshape(-1)
        self.start = grid.start[0] * n_cols + grid.start[1]
        self.targets = np.array(grid.target_indices, dtype=np.int64)
        #: The slot of each target cell in :attr:`targets` (-1 for other cells).
        self.slot = np.full(n_cells, -1, dtype=np.int64)
        self.slot[self.targets] = np.arange(len(self.targets))
        self._distance_rows: dict[int, np.ndarray] = {}

    @property
    def n_cells(self) -> int:
        return self.grid.rows * self.grid.cols

    def index(self, cell: tuple[int, int]) -> int:
        """The index of ``cell``."""
        return int(cell[0]) * self.grid.cols + int(cell[1])

    def distance_table(self, repeat: int = 1) -> np.ndarray | None:
        """The fewest moves between every target and every cell, as one flat int64 array.

        ``table[slot * repeat * cells + repeat * cell + k]`` (for ``k`` below
        ``repeat``) is the distance from ``cell`` to ``targets[slot]``;
        ``repeat`` lets a caller index cells by ``repeat * cell`` directly.
        ``None`` when the table would exceed :data:`DISTANCE_TABLE_ENTRIES`.
        """
        if len(self.targets) * self.n_cells * repeat > DISTANCE_TABLE_ENTRIES:
            return None
        rows = [self._distance_row(int(target)) for target in self.targets]
        return np.repeat(np.stack(rows).astype(np.int64), repeat, axis=1).reshape(-1)

    def optimal_steps(self, cells: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """The fewest moves from each of ``cells`` to the target at the same position,
        for floors too large for :meth:`distance_table` (int64)."""
        if not self.grid.shelves:
            return np.abs(self.rows[cells] - self.rows[targets]) + np.abs(
                self.cols[cells] - self.cols[targets]
            )
        out = np.empty(len(cells), dtype=np.int64)
        for target in np.unique(targets).tolist():
            chosen = targets == target
            out[chosen] = self._cached_row(target)[cells[chosen]]
        return out

    def _distance_row(self, target: int) -> np.ndarray:
        target_cell = (target // self.grid.cols, target % self.grid.cols)
        return self.grid.distance_array(target_cell).reshape(-1)

    def _cached_row(self, target: int) -> np.ndarray:
        row = self._distance_rows.get(target)
        if row is None:
            if (len(self._distance_rows) + 1) * self.n_cells > DISTANCE_TABLE_ENTRIES:
                del self._distance_rows[next(iter(self._distance_rows))]  # the oldest
            row = self._distance_rows[target] = self._distance_row(target)
        return row


def step_rewards(
    arrived: np.ndarray,
    stayed: np.ndarray | None = None,
    step_penalty: float = 0.0,
    bump_penalty: float = 0.0,
) -> np.ndarray:
    """:func:`warehouse_phys.world.grid.step_reward` for many robots: a fresh float64 array.

    ``arrived`` and ``stayed`` are boolean arrays of one shape (``stayed`` may be
    ``None`` when ``bump_penalty`` is 0); the same floating-point operations in the
    same order, so every element equals the single rule's reward bit for bit.
    """
    rewards = np.where(arrived, TARGET_REWARD, 0.0)
    if step_penalty:
        rewards[~arrived] -= step_penalty
    if bump_penalty:
        rewards[stayed] -= bump_penalty
    return rewards
