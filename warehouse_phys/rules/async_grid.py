"""The grid twin of asynchronous execution: robots between cells, tick by tick.

In lock step a robot is always on a cell. Here a move takes ``ticks_needed`` ticks and
a robot may be stopped, or delayed, in the middle of it, so between two ticks each
robot is either *at rest* on a cell or *in mid-move*: the cell it left, the cell it
enters and the ticks of its move done. :class:`AsyncGrid` holds that state and steps it
under each tick's commands (GO or STOP, the cell each robot heads for) and delays,
without judging them: whatever the commands, it reports the cells each robot holds
(both cells in mid-move), and :func:`vertex_conflicts` and :func:`swap_conflicts` say
whether two robots ever held one cell, or crossed one edge in a tick. The commands come
from :class:`~warehouse_phys.rules.executor.Executor`; this world is the one it is
tested against, and the one the physics twin must agree with cell for cell (its bodies
snapped to the cell entered when a move ends).

Like :mod:`warehouse_phys.rules.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.rules.grid import WarehouseGrid
from warehouse_phys.rules.traffic import neighbour_table


class AsyncGrid:
    """Robots between cells on one floor, stepped a tick at a time (see the module).

    Cells are cell indices (``row * cols + col``), as in the fleet's arrays.

    Args:
        grid: The floor.
        cells: ``(N,)`` each robot's cell index, at rest.
        ticks_needed: ``(N,)`` the ticks each robot's move takes (at least 1), or one
            integer for all.

    Raises:
        ValueError: if a cell is not a free cell of the floor or ``ticks_needed`` is
            below 1 or of the wrong shape.
    """

    def __init__(
        self, grid: WarehouseGrid, cells: np.ndarray, ticks_needed: np.ndarray | int = 1
    ) -> None:
        here = np.asarray(cells, dtype=np.int64).reshape(-1)
        if ((here < 0) | (here >= grid.rows * grid.cols)).any() or not grid.free_mask.ravel()[
            here
        ].all():
            raise ValueError("cells must be cell indices of free cells of the floor")
        needed = np.broadcast_to(np.asarray(ticks_needed, dtype=np.int64), here.shape)
        if (needed < 1).any():
            raise ValueError(f"ticks_needed must be at least 1, got {needed.min()}")
        self.grid = grid
        #: The cell each robot is on, or left in mid-move.
        self.left = here.copy()
        #: The cell each robot enters in mid-move; its own cell at rest.
        self.entered = here.copy()
        #: The ticks done of each robot's move (0 at rest).
        self.done = np.zeros(len(here), dtype=np.int64)
        self.ticks_needed = needed.copy()
        self._table = neighbour_table(grid)

    def held(self) -> np.ndarray:
        """``(N, 2)`` the cells each robot holds: the cell it left and the cell it enters,
        the same cell twice at rest."""
        return np.stack([self.left, self.entered], axis=1)

    def step(
        self, go: np.ndarray, heading: np.ndarray, delayed: np.ndarray | None = None
    ) -> np.ndarray:
        """Run one tick and return ``(N,)`` bool, the robots whose move ended in it.

        A robot told GO and not ``delayed`` advances one tick: at rest, it starts a move
        to ``heading`` (a neighbouring free cell; its own cell is no move); in mid-move,
        it goes on (``heading`` must be the cell it enters). Its move ends, and it rests
        on the cell entered, after its ``ticks_needed`` ticks. Any other robot holds.

        Raises:
            ValueError: if ``heading`` sends a robot anywhere else, or ``go`` or
                ``heading`` is not one entry a robot.
        """
        go = np.asarray(go, dtype=bool)
        heading = np.asarray(heading, dtype=np.int64)
        if go.shape != self.left.shape or heading.shape != self.left.shape:
            raise ValueError(f"go and heading need one entry per robot ({len(self.left)})")
        advancing = go if delayed is None else go & ~np.asarray(delayed, dtype=bool)
        in_mid = self.done > 0
        starting = advancing & ~in_mid & (heading != self.left)
        neighbour = (self._table[self.left] == heading[:, None]).any(axis=1)
        bad = (starting & ~neighbour) | (advancing & in_mid & (heading != self.entered))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"heading: robot {i} holds cells {self.left[i]} and {self.entered[i]} and "
                f"cannot head for cell {heading[i]}"
            )
        advancing = advancing & (in_mid | starting)
        self.entered[starting] = heading[starting]
        self.done += advancing
        ended = advancing & (self.done == self.ticks_needed)
        self.left[ended] = self.entered[ended]
        self.done[ended] = 0
        return ended


def vertex_conflicts(held: np.ndarray) -> np.ndarray:
    """The cells held by two or more robots, from ``(N, 2)`` held cells
    (:meth:`AsyncGrid.held`): sorted cell indices, empty when there is none."""
    held = np.asarray(held, dtype=np.int64).reshape(-1, 2)
    cells = np.concatenate([held[:, 0], held[held[:, 1] != held[:, 0], 1]])
    cells.sort()
    return np.unique(cells[1:][cells[1:] == cells[:-1]])


def swap_conflicts(before: np.ndarray, after: np.ndarray) -> int:
    """How many pairs of robots crossed one edge in one tick, in either direction, from
    the cells each held before and after it (``(N, 2)`` each, :meth:`AsyncGrid.held`).

    In a tick a robot holds the cells it held before and after (at most two
    neighbouring cells: it advances one tick of one move). Two robots holding the same
    two cells in one tick either swapped or went the same way, one on top of the other.
    A robot following another into the cell the other leaves holds a different pair.
    """
    before = np.asarray(before, dtype=np.int64).reshape(-1, 2)
    after = np.asarray(after, dtype=np.int64).reshape(-1, 2)
    both = np.concatenate([before, after], axis=1)
    low, high = both.min(axis=1), both.max(axis=1)
    moving = low != high
    keys = low[moving] * (int(high.max(initial=0)) + 1) + high[moving]
    keys.sort()
    return int(np.count_nonzero(keys[1:] == keys[:-1]))
