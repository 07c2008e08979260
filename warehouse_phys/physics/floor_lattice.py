"""Copies of one floor in one space, laid out on a lattice: the batched world's floors.

:class:`FloorLattice` says where each copy of the grid's floor lies in the space of a
:class:`~warehouse_phys.physics.batched.BatchedPhysicsWorld`, which cells a robot may
stand on, turns cells into metres and back, and measures how close robots on the same
floor came (within :data:`GAP_REACH`); :func:`checked_floors` checks which floor each
robot stands on.

Floors are laid out on a square lattice, floor 0 with its top-left corner at
the origin, exactly where the single world has its floor. Chipmunk solves
each robot's joint and contacts with only that robot's bodies and the static
walls (which no impulse moves), so a robot on floor 0 follows the single world
bit for bit. On another floor every coordinate carries the floor's offset, so
positions are rounded to the offset's precision (about ``1e-16`` times the
offset) and a robot there follows the single world to within about ``1e-12``
of a cell, not bit for bit; the tests bound it by ``1e-9``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pymunk

from warehouse_phys.physics.config import PhysicsConfig
from warehouse_phys.physics.engine import WALL_THICKNESS, add_floor, new_space
from warehouse_phys.world.grid import WarehouseGrid

#: Empty floor between the walls of two neighbouring floors [cells].
FLOOR_GAP = 1.0

#: Farthest apart two robots' cells may be at the start of a move, counted in steps
#: along rows and columns, for their discs to touch during it [cells]. A centre moves
#: along one axis, at most 1 + e cells, and drifts sideways at most s, where the fleet's
#: clearance check keeps e and s below (1 - d) / 2 for discs of diameter d < 1; so two
#: centres' row-and-column distance changes by at most 4 - 2d, and discs that touch
#: are less than sqrt(2) d apart that way: they started less than 4 apart.
GAP_REACH = 3


class FloorLattice:
    """Where each robot's floor lies [m], and which of its cells a robot may stand on.

    Args:
        grid: The floor every copy repeats.
        size: The side of a cell [m].
        floor_of: ``(N,)`` int64, the floor each robot stands on (:func:`checked_floors`).
        n_floors: How many floors there are.
    """

    def __init__(
        self, grid: WarehouseGrid, size: float, floor_of: np.ndarray, n_floors: int
    ) -> None:
        self.grid = grid
        self.size = size
        self.floor_of = floor_of
        #: ``(floors, 2)`` float64: each floor's top-left corner ``(x, y)`` [m].
        self.origins = floor_origins(grid, size, n_floors)
        #: ``(N, 2)`` float64: the corner of each robot's floor [m].
        self.origin = self.origins[floor_of]
        self._free_padded = padded_free_cells(grid)
        self._padded_strides = np.array([1, grid.cols + 2], dtype=np.int64)  # (col, row)
        self._clip_high = np.array([grid.cols, grid.rows], dtype=np.int64)

    def new_space(self, config: PhysicsConfig) -> pymunk.Space:
        """A new space (:func:`~warehouse_phys.physics.engine.new_space`) with the walls and
        shelves of every floor."""
        space = new_space(config)
        for origin in self.origins.tolist():
            add_floor(space, self.grid, self.size, tuple(origin))
        return space

    def centres(self, cells: np.ndarray, robots: np.ndarray | None = None) -> np.ndarray:
        """The centres ``(x, y)`` [m] of ``cells`` (``(k, 2)`` row, col) on the floors of
        ``robots`` (default: every robot, in order)."""
        origin = self.origin if robots is None else self.origin[robots]
        return (cells[:, ::-1] + 0.5) * self.size + origin

    def to_cells(self, xy: np.ndarray) -> np.ndarray:
        """``(..., N, 2)`` positions ``(x, y)`` [m] as ``(row, col)`` in cells on each floor."""
        return ((xy - self.origin) / self.size - 0.5)[..., ::-1]

    def cells_of(self, xy: np.ndarray) -> np.ndarray:
        """The ``(col, row)`` of the cell each robot's ``(x, y)`` [m] lies in (the centre
        nearest to it).

        Raises:
            RuntimeError: if a position is not finite or off the floor or on a shelf.
        """
        local = xy - self.origin
        if not np.isfinite(local).all():
            robot = int(np.flatnonzero(~np.isfinite(local).all(axis=1))[0])
            raise RuntimeError(f"robot {robot}'s position became {tuple(xy[robot].tolist())}")
        cells_xy = np.floor(local / self.size).astype(np.int64)
        lost = ~self.on_free_cell(cells_xy)
        if lost.any():
            robot = int(np.flatnonzero(lost)[0])
            x, y = local[robot].tolist()
            raise RuntimeError(
                f"robot {robot} left the floor or entered a shelf: it is at ({x:.3f}, {y:.3f}) m"
            )
        return cells_xy

    def on_free_cell(self, cells_xy: np.ndarray) -> np.ndarray:
        """Whether each ``(col, row)`` is a cell a robot may stand on."""
        # _free_padded has a border of False around the floor: clip anything beyond onto it.
        padded = np.minimum(np.maximum(cells_xy, -1), self._clip_high) + 1  # (np.clip is slower)
        return self._free_padded[padded @ self._padded_strides]

    def check_cells(self, cells: np.ndarray, name: str) -> None:
        """Refuse ``cells`` (``(N, 2)`` row, col) a robot may not stand on, naming the
        first robot's ``name`` (its start, say)."""
        bad = ~self.on_free_cell(cells[:, ::-1])
        if bad.any():
            robot = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"robot {robot}'s {name} {tuple(cells[robot].tolist())} is off the "
                f"{self.grid.rows}x{self.grid.cols} floor, on a shelf or out of reach"
            )

    def check_one_per_cell(self, cells: np.ndarray, name: str) -> None:
        """Refuse two robots' ``cells`` (``(N, 2)``) on the same cell of the same floor."""
        keys = self.floor_of * (self.grid.rows * self.grid.cols) + (
            cells[:, 0] * self.grid.cols + cells[:, 1]
        )
        unique, counts = np.unique(keys, return_counts=True)
        if (counts > 1).any():
            shared = unique[counts > 1][0]
            robots = np.flatnonzero(keys == shared).tolist()
            raise ValueError(f"robots {robots} {name} on the same cell of the same floor")

    def closest_approach(self, path_xy: np.ndarray, starts: np.ndarray, reach: int) -> np.ndarray:
        """How close each robot's centre came to another's on the same floor [cells]:
        ``(N,)``, compared at every step of ``path_xy`` (``(steps, N, 2)`` positions
        ``(x, y)`` [m]) for the robots whose ``starts`` (``(N, 2)`` cells) were at most
        ``reach`` steps apart along rows and columns (a k-d tree finds them); ``inf`` for
        a robot with none (see
        :meth:`~warehouse_phys.physics.batched.BatchedPhysicsWorld.closest_approach`)."""
        n_robots = len(starts)
        closest = np.full(n_robots, np.inf)
        if n_robots < 2 or not len(path_xy):
            return closest
        several = len(self.origins) > 1
        if several:  # each floor where it lies: more than 3 cells from the next
            starts = starts + self.origin[:, ::-1] / self.size
        from scipy.spatial import cKDTree  # here: 0.3 s to import, for fleets of bodies

        pairs = cKDTree(starts).query_pairs(reach, p=1, output_type="ndarray")
        first, second = pairs[:, 0], pairs[:, 1]
        if several:
            same = self.floor_of[first] == self.floor_of[second]
            first, second = first[same], second[same]
        if len(first):
            # Robot by robot: each pair's two paths are two contiguous rows.
            path = self.to_cells(path_xy).transpose(1, 0, 2).reshape(n_robots, -1)
            offset = path[first] - path[second]  # (pairs, steps * 2): row, col, row, ...
            offset *= offset
            apart = np.sqrt((offset[:, 0::2] + offset[:, 1::2]).min(axis=1))
            np.minimum.at(closest, first, apart)
            np.minimum.at(closest, second, apart)
        return closest


def checked_floors(
    floor_of: np.ndarray | Sequence[int] | None, n_robots: int
) -> tuple[np.ndarray, int]:
    """Each robot's floor as ``(N,)`` int64 (default: one floor each), and the number of
    floors; a ``ValueError`` unless they are numbered 0, 1, ... with none left out."""
    floor_of = (
        np.arange(n_robots, dtype=np.int64)
        if floor_of is None
        else np.array(floor_of, dtype=np.int64).reshape(-1)
    )
    if floor_of.shape != (n_robots,):
        raise ValueError(
            f"floor_of must have one floor per robot ({n_robots}), got shape {floor_of.shape}"
        )
    n_floors = int(floor_of.max()) + 1
    if floor_of.min() < 0 or len(np.unique(floor_of)) != n_floors:
        raise ValueError("floors must be numbered 0, 1, ... with none left out")
    return floor_of, n_floors


def padded_free_cells(grid: WarehouseGrid) -> np.ndarray:
    """Whether a robot may stand on each cell, flat, with a border of False all round:
    ``(rows + 2) * (cols + 2)`` bools, cell ``(row, col)`` at ``(row + 1) (cols + 2) + col + 1``."""
    free = np.zeros((grid.rows + 2, grid.cols + 2), dtype=bool)
    free[1:-1, 1:-1] = grid.reachable_mask  # (not cell by cell: 70,000 on warehouse-large)
    return free.ravel()


def floor_origins(grid: WarehouseGrid, size: float, n_floors: int) -> np.ndarray:
    """The floors' top-left corners ``(x, y)`` [m], ``(floors, 2)``: a square lattice,
    floor 0 at the origin, :data:`FLOOR_GAP` between the walls of neighbours."""
    side = math.ceil(math.sqrt(n_floors))
    pitch_x = (grid.cols + 2 * WALL_THICKNESS + FLOOR_GAP) * size
    pitch_y = (grid.rows + 2 * WALL_THICKNESS + FLOOR_GAP) * size
    floors = np.arange(n_floors)
    return np.stack([floors % side * pitch_x, floors // side * pitch_y], axis=1)
