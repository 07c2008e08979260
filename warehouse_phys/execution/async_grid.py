"""The grid twin of asynchronous execution: robots between cells, tick by tick.

In lock step a robot is always on a cell. Here a move takes ``ticks_needed`` ticks and
a robot may be stopped, or delayed, in the middle of it, so between two ticks each
robot is either *at rest* on a cell or *in mid-move*: the cell it left, the cell it
enters and the ticks of its move done; its centre (:meth:`AsyncGrid.centres`) is that
share of the way between the two cells' centres, and moves linearly within a tick.
:class:`AsyncGrid` holds that state and steps it under each tick's commands (GO or
STOP, the cell each robot heads for) and delays, without judging them: whatever the
commands, it reports the cells each robot holds (both cells in mid-move) and its
centre. :func:`gap_conflicts` says whether two centres came closer than a gap during a
tick (two robots in one place is the extreme case), :func:`swap_conflicts` whether two
robots crossed one edge in a tick, and :func:`vertex_conflicts` which cells two robots
hold at once (a conflict for robots at rest, as lock step checks them; in mid-move a
follower entering the cell its leader leaves holds it too). The commands come
from :class:`~warehouse_phys.execution.executor.Executor`; this world is the one it is
tested against, and the one the physics twin must agree with cell for cell (its bodies
snapped to the cell entered when a move ends).

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.traffic import neighbour_table

#: Relative slack of gap checks, for centres computed in floating point.
GAP_SLACK = 1e-9


class AsyncGrid:
    """Robots between cells on one floor, stepped a tick at a time (see the module).

    Cells are cell indices (``row * cols + col``), as in the fleet's arrays.

    Args:
        grid: The floor.
        cells: ``(N,)`` each robot's cell index, at rest.
        ticks_needed: ``(N,)`` the ticks each robot's move takes (at least 1), or one
            integer for all.
        headings: ``(N,)`` turning robots' headings (0..3): a turn takes the ticks of a
            move, in place; ``None`` for four-direction robots.

    Raises:
        ValueError: if a cell is not a free cell of the floor or ``ticks_needed`` is
            below 1 or of the wrong shape.
    """

    def __init__(
        self,
        grid: WarehouseGrid,
        cells: np.ndarray,
        ticks_needed: np.ndarray | int = 1,
        headings: np.ndarray | None = None,
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
        #: Turning robots: each robot's heading, and the one its turn ends facing (its
        #: heading when it is not turning); ``None`` for four-direction robots.
        self.headings = None if headings is None else np.array(headings, dtype=np.int64)
        self.facing = None if headings is None else self.headings.copy()
        self._table = neighbour_table(grid)

    def held(self) -> np.ndarray:
        """``(N, 2)`` the cells each robot holds: the cell it left and the cell it enters,
        the same cell twice at rest."""
        return np.stack([self.left, self.entered], axis=1)

    def centres(self) -> np.ndarray:
        """``(N, 2)`` float, each robot's centre as ``(row, col)`` in cells: the share
        ``done / ticks_needed`` of the way from the cell it left to the cell it enters."""
        share = (self.done / self.ticks_needed)[:, None]
        start = np.stack(np.divmod(self.left, self.grid.cols), axis=1)
        end = np.stack(np.divmod(self.entered, self.grid.cols), axis=1)
        return start + share * (end - start)

    def step(
        self,
        go: np.ndarray,
        heading: np.ndarray,
        delayed: np.ndarray | None = None,
        facing: np.ndarray | None = None,
    ) -> np.ndarray:
        """Run one tick and return ``(N,)`` bool, the robots whose move ended in it.

        A robot told GO and not ``delayed`` advances one tick: at rest, it starts a move
        to ``heading`` (a neighbouring free cell; its own cell is no move); in mid-move,
        it goes on (``heading`` must be the cell it enters). Its move ends, and it rests
        on the cell entered, after its ``ticks_needed`` ticks. Any other robot holds.
        Turning robots: ``facing`` (``(N,)``) is the heading each robot's action ends
        facing; at rest with ``heading`` its own cell, a different ``facing`` (a quarter
        turn away) starts a turn in place.

        Raises:
            ValueError: if ``heading`` or ``facing`` sends a robot anywhere else, or
                ``go`` or ``heading`` is not one entry a robot.
        """
        go = np.asarray(go, dtype=bool)
        heading = np.asarray(heading, dtype=np.int64)
        if go.shape != self.left.shape or heading.shape != self.left.shape:
            raise ValueError(f"go and heading need one entry per robot ({len(self.left)})")
        if (facing is None) != (self.headings is None):
            raise ValueError("facing: turning robots need it, four-direction robots take none")
        advancing = go if delayed is None else go & ~np.asarray(delayed, dtype=bool)
        in_mid = self.done > 0
        turn = self._turns(advancing & ~in_mid & (heading == self.left), facing)
        starting = advancing & ~in_mid & ((heading != self.left) | turn)
        neighbour = (self._table[self.left] == heading[:, None]).any(axis=1)
        bad = (starting & ~turn & ~neighbour) | (advancing & in_mid & (heading != self.entered))
        if facing is not None:
            bad |= advancing & in_mid & (np.asarray(facing) != self.facing)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"heading: robot {i} holds cells {self.left[i]} and {self.entered[i]} and "
                f"cannot head for cell {heading[i]}"
            )
        advancing = advancing & (in_mid | starting)
        self.entered[starting] = heading[starting]
        if facing is not None:
            self.facing[starting] = np.asarray(facing)[starting]
        self.done += advancing
        ended = advancing & (self.done == self.ticks_needed)
        self.left[ended] = self.entered[ended]
        if facing is not None:
            self.headings[ended] = self.facing[ended]
        self.done[ended] = 0
        return ended

    def _turns(self, still: np.ndarray, facing: np.ndarray | None) -> np.ndarray:
        """Which robots of ``still`` (at rest, told to keep their cell) start a turn; a
        ``ValueError`` for a turn that is not a quarter turn."""
        if facing is None:
            return np.zeros_like(still)
        change = (np.asarray(facing, dtype=np.int64) - self.headings) % 4
        if (still & (change == 2)).any():
            i = int(np.flatnonzero(still & (change == 2))[0])
            raise ValueError(f"facing: robot {i} cannot turn from {self.headings[i]} to "
                             f"{facing[i]} in one action")  # fmt: skip
        return still & (change != 0)


def vertex_conflicts(held: np.ndarray) -> np.ndarray:
    """The cells held by two or more robots, from ``(N, 2)`` held cells
    (:meth:`AsyncGrid.held`): sorted cell indices, empty when there is none."""
    held = np.asarray(held, dtype=np.int64).reshape(-1, 2)
    cells = np.concatenate([held[:, 0], held[held[:, 1] != held[:, 0], 1]])
    cells.sort()
    return np.unique(cells[1:][cells[1:] == cells[:-1]])


def closest_squared(start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """``(K,)`` the least squared length of ``start + t (end - start)`` for ``t`` in
    ``[0, 1]``: how close two centres that move linearly come, from their differences
    ``(K, 2)`` at the start and the end of a tick."""
    motion = end - start
    length = (motion * motion).sum(axis=1)
    t = np.clip(-(start * motion).sum(axis=1) / np.where(length > 0, length, 1.0), 0.0, 1.0)
    nearest = start + t[:, None] * motion
    return (nearest * nearest).sum(axis=1)


def gap_conflicts(
    held: tuple[np.ndarray, np.ndarray],
    centres: tuple[np.ndarray, np.ndarray],
    min_gap: float,
) -> int:
    """How many pairs of robots came closer than ``min_gap`` cells during one tick, from
    the cells each held and its centre before and after the tick (``(N, 2)`` arrays each,
    :meth:`AsyncGrid.held` and :meth:`AsyncGrid.centres`), the centres moving linearly.

    Only robots that held a common cell in the tick are compared: the others are on
    disjoint edges of the grid of cell centres, at least one cell apart. O(N log N).
    """
    both = np.concatenate([np.asarray(h, dtype=np.int64).reshape(-1, 2) for h in held], axis=1)
    n = len(both)
    robot = np.repeat(np.arange(n), 4)
    cells = both.ravel()
    keep = np.ones(len(cells), dtype=bool)  # each robot's cells once
    order = np.lexsort((cells, robot))
    keep[order[1:]] = (cells[order[1:]] != cells[order[:-1]]) | (
        robot[order[1:]] != robot[order[:-1]]
    )
    cells, robot = cells[keep], robot[keep]
    order = np.argsort(cells, kind="stable")
    cells, robot = cells[order], robot[order]
    pairs = []
    for offset in range(1, len(cells)):  # robots sharing a cell, two at a time
        same = cells[offset:] == cells[:-offset]
        if not same.any():
            break
        pairs.append(np.stack([robot[:-offset][same], robot[offset:][same]], axis=1))
    if not pairs:
        return 0
    pairs = np.unique(np.sort(np.concatenate(pairs), axis=1), axis=0)
    before, after = (np.asarray(c, dtype=np.float64).reshape(-1, 2) for c in centres)
    start = before[pairs[:, 1]] - before[pairs[:, 0]]
    end = after[pairs[:, 1]] - after[pairs[:, 0]]
    least = float(min_gap) ** 2 * (1 - GAP_SLACK)
    return int(np.count_nonzero(closest_squared(start, end) < least))


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
