"""The floor as PIBT plans on it: cells by index, the cells parked robots hold, and the
exits and distances round them.

:class:`PlanningFloor` holds what :class:`~warehouse_phys.planners.pibt.PIBT` and its parts
(the swap operation, the straight-line pushes, turning robots' actions) read of the floor:
the traffic rule's neighbour table (``table[cell, action]``, the cell each move leads to),
the action of each change of cell index, and, round the cells held by parked robots (which
never move again, so to the planner they are walls), each cell's exits and each robot's
distances to its goal. :data:`NIL` is "no robot" / "not planned yet" in the planner's
arrays.
"""

from __future__ import annotations

import contextlib

import numpy as np

from warehouse_phys.planners.distances import DistanceMaps
from warehouse_phys.world.grid import ACTION_DELTAS, WarehouseGrid
from warehouse_phys.world.traffic import WAIT, neighbour_table

#: "No robot" / "not planned yet" in the planner's arrays.
NIL = -1
#: Floors of at most this many cells keep every cell's exits as lists (faster checks).
_EXITS_LISTED = 200_000


class PlanningFloor:
    """One floor as PIBT plans on it (the module's docstring), with the cells held now.

    Args:
        grid: The floor.
        distances: Its distance maps (on the floor without held cells).
    """

    def __init__(self, grid: WarehouseGrid, distances: DistanceMaps) -> None:
        self.grid = grid
        self.distances = distances
        #: Each cell's neighbouring cell by action (the traffic rule's table).
        self.table = neighbour_table(grid)
        cols = grid.cols
        #: The action of a move by its change of cell index plus ``cols`` (WAIT for 0).
        self.action_of = [WAIT] * (2 * cols + 1)
        for action, (d_row, d_col) in enumerate(ACTION_DELTAS):
            self.action_of[d_row * cols + d_col + cols] = action
        #: Distances round the robots that hold their cells (parked), and those cells.
        self.around: DistanceMaps = distances
        self.held = np.empty(0, dtype=np.int64)
        #: Each cell's neighbouring cells a robot can enter (no shelf, no held cell).
        self._exits_of: list[list[int]] = []
        self._set_exits(self.held)
        #: Per plan: each robot's goal, and whether its distances ignore the held cells.
        self.goals: list[int] = []
        self.plain: np.ndarray = np.zeros(0, dtype=bool)

    def distances_round(self, held: np.ndarray) -> DistanceMaps:
        """Distances on the floor with the ``held`` cells (parked robots, which never move
        again) as obstacles: without them a robot whose shortest path runs through a
        parked robot would wait beside it for ever. Rebuilt when the held cells change."""
        if not np.array_equal(held, self.held):
            self.held = held
            self._set_exits(held)
            self.around = self.distances
            if held.size:
                cols = self.grid.cols
                floor = np.where(self.grid.shelf_mask, "#", ".")
                floor[held // cols, held % cols] = "#"
                rows = ["".join(row) for row in floor.tolist()]
                with contextlib.suppress(ValueError):  # held cells that leave no floor
                    self.around = DistanceMaps(
                        WarehouseGrid.from_layout(rows), max_bytes=self.distances.max_bytes
                    )
        return self.around

    def aim(self, goal: np.ndarray) -> None:
        """Set each robot's ``goal`` (cell indices) for this plan, after
        :meth:`distances_round`: a robot whose goal is a held cell keeps the plain
        distances (it could not reach its goal round them)."""
        self.goals = goal.tolist()
        self.plain = np.isin(goal, self.held) if self.held.size else np.ones(len(goal), dtype=bool)

    def distance(self, robot: int, cell: int) -> int:
        """Robot ``robot``'s distance from ``cell`` to its goal, on the same maps as its
        candidates."""
        maps = self.distances if self.plain[robot] else self.around
        return maps.distance(cell, self.goals[robot])

    def _set_exits(self, held: np.ndarray) -> None:
        """The cells a robot can enter from each cell: moves that stay on the floor, off
        the shelves and off the ``held`` cells (the swap operation's graph)."""
        cells = np.arange(len(self.table))
        moves = self.table[:, :WAIT]
        enterable = moves != cells[:, None]
        if held.size:
            enterable &= ~np.isin(moves, held)
        self._exits_of = (
            [row[ok].tolist() for row, ok in zip(moves, enterable, strict=True)]
            if len(cells) <= _EXITS_LISTED
            else []
        )
        self._moves, self._enterable = moves, enterable
        #: How many exits each cell has.
        self.exit_count = enterable.sum(axis=1)

    def exits(self, cell: int) -> list[int]:
        """The neighbouring cells a robot on ``cell`` can enter (no shelf, no held cell)."""
        if self._exits_of:
            return self._exits_of[cell]
        return self._moves[cell][self._enterable[cell]].tolist()
