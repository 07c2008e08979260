"""The pure warehouse world: cells, actions, moves, targets and optimal distances.

Every environment of the package follows these rules, so the grid twin and the
physics-backed environment cannot drift apart. This module imports neither
gymnasium, pymunk nor pygame: only numpy (for the random generator type and the
floor's masks) and, for a floor drawn as text, scipy's region labelling.

A floor is held as arrays (a byte or so a cell; see
:data:`~warehouse_phys.world.layout_text.MAX_SIDE`): boolean masks of
its free, shelf and reachable cells and the indices of its package cells.
:attr:`WarehouseGrid.shelves`, :attr:`~WarehouseGrid.reachable` and
:attr:`~WarehouseGrid.target_cells` are read-only views of them that behave as the
frozensets and the tuple of :class:`Cell` they once were.

A floor drawn as text is read by :mod:`warehouse_phys.world.layout_text`, which also
holds the size a floor may have; its names still import from here.
"""

from __future__ import annotations

import array
import functools
import itertools
from collections.abc import Iterator, Sequence
from enum import IntEnum
from typing import Any

import numpy as np

from warehouse_phys.world.cells import Cell, CellSequence, CellSet, read_only
from warehouse_phys.world.floor_regions import label_regions

# A floor drawn as text and the size limits live in layout_text; re-exported here, where
# they lived first (see __all__).
from warehouse_phys.world.layout_text import (
    FLOOR,
    LAYOUT_SYMBOLS,
    LISTED_CELLS,
    MAX_SIDE,
    MIN_SIDE,
    PACKAGE,
    SHELF,
    START,
    cell_list,
    check_size,
    checked_layout,
    package_cells,
    unmarked_start,
)


class Action(IntEnum):
    """The four moves of the robot, numbered as in the action space."""

    LEFT = 0
    DOWN = 1
    RIGHT = 2
    UP = 3


#: The (row, column) change of each action, indexed by the action's value.
ACTION_DELTAS: tuple[tuple[int, int], ...] = (
    (0, -1),  # LEFT
    (1, 0),  # DOWN
    (0, 1),  # RIGHT
    (-1, 0),  # UP
)

#: The default floor [cells]: 4 rows of 5 cells, the size every environment starts with.
DEFAULT_ROWS, DEFAULT_COLS = 4, 5

#: Where the robot stands after every reset.
START_CELL = Cell(0, 0)

#: Reward for standing on the target; every other step earns nothing.
TARGET_REWARD = 1.0


#: Distance maps kept for :meth:`WarehouseGrid.optimal_steps`, counted in cells
#: (4 bytes each): about 8 MB, whatever the floor.
DISTANCE_CACHE_CELLS = 2**21


class WarehouseGrid:
    """A rectangular warehouse floor: its size, its shelves, and the rules on it.

    ``WarehouseGrid(rows, cols)`` is the empty floor: no shelves, the robot
    starting at (0, 0) and targets in rows 1..R-1 and columns 1..C-1.
    :meth:`from_layout` builds a floor with shelves from text.

    The grid knows the rules and nothing about episodes: where a move leads,
    which cells may hold the target, how a target is drawn and how far any
    cell is from it.

    Raises:
        TypeError: if ``rows`` or ``cols`` is not an integer.
        ValueError: if the grid has fewer than 2 rows or 2 columns, which
            would leave no cell for the target outside row 0 and column 0.
    """

    __slots__ = (
        "_distance_cache_size",
        "_distances",
        "_free",
        "_open_floor",
        "cols",
        "free_mask",
        "layout",
        "reachable",
        "reachable_mask",
        "rows",
        "shelf_mask",
        "shelves",
        "start",
        "starts",
        "starts_marked",
        "target_cells",
        "target_indices",
    )

    def __init__(self, rows: int, cols: int) -> None:
        rows = check_size("grid_rows", rows)
        cols = check_size("grid_cols", cols)
        free = np.ones((rows, cols), dtype=bool)
        self._setup(free, free, START_CELL, layout=None)  # an empty floor is connected
        targets = np.zeros((rows, cols), dtype=bool)
        targets[1:, 1:] = True
        self._set_targets(np.flatnonzero(targets))

    @classmethod
    def from_layout(cls, layout: Sequence[str]) -> WarehouseGrid:
        """A floor drawn as text: one string per row, one symbol per cell.

        ``.`` is floor, ``#`` a shelf, ``P`` floor on which packages may
        appear and ``S`` a start: the first ``S`` in reading order is the
        robot's, and a fleet (:mod:`warehouse_phys.envs.fleet`) puts a robot on
        each. Without ``S`` (:attr:`starts_marked` is then False) the robot
        starts on the first cell in reading order of the largest region of
        floor connected by moves, so that it reaches the most floor: ``(0, 0)``
        on a connected floor whose corner is free. When the layout marks ``P``
        cells, only the regions holding one compete, and the start is the
        region's first cell that is not a ``P`` (a ``P`` only if the region has
        nothing else), so no package is lost to the start. Without ``P``,
        packages may appear on every floor cell the robot can reach, except
        the starts. Cells are reached by moves between free neighbours; floor
        that cannot be reached is allowed (an office, say) but never holds a
        package.

        Raises:
            TypeError: if ``layout`` is not a sequence of strings.
            ValueError: naming the row and column, for an empty layout, rows of
                different lengths, an unknown symbol, no floor at all, a start the
                first start cannot reach, ``P`` cells the robot cannot reach, or no cell at
                all for a package.
        """
        rows, symbols = checked_layout(layout)
        width = len(rows[0])
        free = symbols != ord(SHELF)
        # Regions of free cells connected by moves (4-connected), numbered in reading order.
        regions, count = label_regions(free)
        marked = np.flatnonzero(symbols == ord(START))
        if marked.size:
            start = Cell(*divmod(int(marked[0]), width))
        else:
            start = unmarked_start(symbols, regions, count)
        grid = cls.__new__(cls)
        grid._setup(free, regions == regions[start], start, layout=tuple(rows))
        del regions  # 4 bytes a cell: gone before the package cells are found
        stranded = marked[~grid.reachable_mask.flat[marked]]
        if stranded.size:
            raise ValueError(
                f"start cells {cell_list(CellSequence(stranded, len(rows), width))} cannot be "
                f"reached from the start {tuple(start)}"
            )
        grid.starts = tuple(Cell(*divmod(i, width)) for i in marked.tolist()) or (start,)
        grid.starts_marked = bool(marked.size)
        grid._set_targets(package_cells(grid, symbols))
        return grid

    def _setup(
        self,
        free: np.ndarray,
        reachable: np.ndarray,
        start: Cell,
        *,
        layout: tuple[str, ...] | None,
    ) -> None:
        self.rows, self.cols = rows, cols = free.shape
        #: Which cells the robot may stand on (not shelves): a read-only ``(rows, cols)``
        #: boolean array.
        self.free_mask = read_only(free)
        #: The shelf cells, ``~free_mask``: a read-only ``(rows, cols)`` boolean array.
        self.shelf_mask = read_only(~free)
        self._open_floor = bool(free.all())  # no shelves: distances are Manhattan's
        #: The cells the robot can reach from the start: a read-only ``(rows, cols)``
        #: boolean array.
        self.reachable_mask = read_only(reachable)
        #: The shelf cells, a read-only set of cells (:class:`CellSet`, equal to the
        #: frozenset of them); the robot can never stand on one.
        self.shelves = CellSet(self.shelf_mask)
        #: Every cell the robot can reach from the start (a :class:`CellSet`).
        self.reachable = CellSet(self.reachable_mask)
        #: Where the robot stands after every reset.
        self.start = start
        #: Every start cell of the layout in reading order, ``start`` first; ``(start,)``
        #: on the empty floor. A fleet puts a robot on each.
        self.starts = (start,)
        #: Whether the start was given: by ``S`` cells of a layout, or as the corner of a
        #: plain floor. False for a layout without ``S`` (a benchmark map, say), whose
        #: start is the first cell of its largest region; a fleet there draws its starts.
        self.starts_marked = True
        #: The layout's text, or ``None`` for the empty floor.
        self.layout = layout
        # One bytes object per row, a byte a cell: ``move`` and ``is_free`` look cells up
        # with two indexings and no numpy call, on the single robot's hot path.
        flat = free.astype(np.uint8).tobytes()
        self._free = [flat[row * cols : (row + 1) * cols] for row in range(rows)]
        self._distances: dict[Cell, list[array.array]] = {}
        # Each cached distance map holds one entry per cell: keep at most about
        # DISTANCE_CACHE_CELLS entries in all, and at least a few maps.
        self._distance_cache_size = max(4, DISTANCE_CACHE_CELLS // (rows * cols))

    def _set_targets(self, indices: np.ndarray) -> None:
        #: Every cell the target may be placed on, as read-only, ascending int64 indices
        #: ``row * cols + col``.
        self.target_indices = read_only(indices.astype(np.int64, copy=False))
        #: Every cell the target may be placed on, in row-major order (a
        #: :class:`CellSequence`, equal to the tuple of them). On the empty floor: rows
        #: 1..R-1 and columns 1..C-1, so never the start's row or column.
        self.target_cells = CellSequence(self.target_indices, self.rows, self.cols)

    def __setstate__(self, state: tuple[None, dict[str, Any]]) -> None:
        for name, value in state[1].items():
            setattr(self, name, value)
        for values in (self.free_mask, self.shelf_mask, self.reachable_mask, self.target_indices):
            values.flags.writeable = False  # a copy or a pickle keeps them read-only

    def __repr__(self) -> str:
        if self.layout is None:
            return f"WarehouseGrid(rows={self.rows}, cols={self.cols})"
        return f"WarehouseGrid.from_layout({list(self.layout)!r})"

    def contains(self, cell: tuple[int, int]) -> bool:
        """Whether ``cell`` lies on the floor (shelf cells included)."""
        row, col = cell
        return 0 <= row < self.rows and 0 <= col < self.cols

    def is_free(self, cell: tuple[int, int]) -> bool:
        """Whether the robot may stand on ``cell``: on the floor and not a shelf."""
        row, col = cell
        return 0 <= row < self.rows and 0 <= col < self.cols and self._free[row][col] == 1

    def move(self, cell: tuple[int, int], action: int) -> Cell:
        """The cell reached from ``cell`` by ``action``.

        A move off the floor or into a shelf leaves the robot where it is.
        """
        d_row, d_col = ACTION_DELTAS[action]
        row, col = cell[0] + d_row, cell[1] + d_col
        if 0 <= row < self.rows and 0 <= col < self.cols and self._free[row][col]:
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
        skipped = cells._position(exclude) if exclude is not None else -1
        if skipped < 0:
            return cells[int(rng.integers(len(cells)))]
        # The draw among the other cells, as if ``exclude`` were taken out of the list.
        drawn = int(rng.integers(len(cells) - 1))
        return cells[drawn + (drawn >= skipped)]

    def optimal_steps(self, cell: tuple[int, int], target: tuple[int, int]) -> int:
        """The fewest actions that take the robot from ``cell`` to ``target``.

        On an empty floor this is the Manhattan distance; around shelves it
        comes from a breadth-first search over the free cells (cached per target).

        Raises:
            ValueError: if ``target`` cannot be reached from ``cell``.
        """
        if self._open_floor:
            return abs(cell[0] - target[0]) + abs(cell[1] - target[1])
        distances = self._distances.get(target)
        if distances is None:
            if len(self._distances) >= self._distance_cache_size:
                del self._distances[next(iter(self._distances))]  # the oldest
            # A row of 4-byte integers per row of cells (an array.array): half the memory of
            # lists, and two indexings give a Python int at once, as fast as lists.
            flat = self._distances_from(target)
            distances = [array.array("i", row.tobytes()) for row in flat.reshape(self.rows, -1)]
            self._distances[Cell(*target)] = distances
        steps = distances[cell[0]][cell[1]]
        if steps < 0:
            raise ValueError(f"{tuple(target)} cannot be reached from {tuple(cell)}")
        return steps

    def distance_map(self, target: tuple[int, int]) -> list[list[int]]:
        """The fewest moves from every cell to ``target`` (``-1`` where it cannot be
        reached, shelves included), as ``rows`` lists of ``cols`` integers; the
        distances :meth:`optimal_steps` gives. A fresh list."""
        return self.distance_array(target).tolist()

    def distance_array(self, target: tuple[int, int]) -> np.ndarray:
        """:meth:`distance_map` as a fresh ``(rows, cols)`` int32 array (``-1`` where
        ``target`` cannot be reached, shelves included)."""
        if self._open_floor:
            rows = np.abs(np.arange(self.rows, dtype=np.int32) - target[0])
            cols = np.abs(np.arange(self.cols, dtype=np.int32) - target[1])
            return rows[:, None] + cols[None, :]
        return self._distances_from(target).reshape(self.rows, self.cols)

    def _distances_from(self, origin: tuple[int, int]) -> np.ndarray:
        """Moves from ``origin`` to every cell (the same both ways), flat int32; -1 where it
        cannot go. A breadth-first search one layer at a time, each layer a few array
        operations over a copy of the floor framed by shelves (no bounds checks)."""
        width = self.cols + 2
        unseen = np.zeros((self.rows + 2, width), dtype=bool)
        unseen[1:-1, 1:-1] = self.free_mask
        unseen = unseen.reshape(-1)
        distances = np.full(unseen.size, -1, dtype=np.int32)
        frontier = np.array([(origin[0] + 1) * width + origin[1] + 1], dtype=np.int64)
        if self.is_free(origin):
            unseen[frontier] = False
            distances[frontier] = 0
        else:
            frontier = frontier[:0]
        offsets = np.array([-1, width, 1, -width], dtype=np.int64)
        steps = 0
        while frontier.size:
            steps += 1
            reached = (frontier[:, None] + offsets).reshape(-1)
            reached = np.unique(reached[unseen[reached]])
            unseen[reached] = False
            distances[reached] = steps
            frontier = reached
        return distances.reshape(self.rows + 2, width)[1:-1, 1:-1].reshape(-1)

    def random_walk_finish_rate(self, steps: int) -> float:
        """The chance that uniformly random actions reach the target within ``steps`` actions.

        Averaged over the targets, each equally likely, from the start; computed
        exactly by evolving the walk's distribution over the reachable cells
        with the target made absorbing. Time limits are chosen with it.
        """
        return next(itertools.islice(self._finish_rates(), steps, None))

    def random_walk_time_limit(self, finish_rate: float, granularity: int) -> int:
        """The fewest whole ``granularity`` steps within which a uniformly random walk
        reaches the target with probability at least ``finish_rate`` (see
        :meth:`random_walk_finish_rate`). The cost grows with the cube of the
        number of reachable cells: meant for small floors."""
        for steps, rate in enumerate(self._finish_rates()):
            if steps and steps % granularity == 0 and rate >= finish_rate:
                return steps
        raise AssertionError("unreachable: the rates never end")  # pragma: no cover

    def _finish_rates(self) -> Iterator[float]:
        """The chance of having reached the target after 0, 1, 2, ... random actions."""
        cells = sorted(self.reachable)
        index = {cell: i for i, cell in enumerate(cells)}
        # The cells each cell's chance comes from in one step, once per action leading
        # there, padded with a cell of no chance (index len(cells)). A step gathers a
        # quarter of each rather than multiplying by the (mostly zero) transition matrix,
        # whose BLAS threads cost several times the arithmetic on floors this small.
        sources: list[list[int]] = [[] for _ in cells]
        for i, cell in enumerate(cells):
            for action in range(len(ACTION_DELTAS)):
                sources[index[self.move(cell, action)]].append(i)
        width = max(len(came_from) for came_from in sources)
        comes_from = np.array([came_from + [len(cells)] * (width - len(came_from))
                               for came_from in sources])  # fmt: skip
        share = 1.0 / len(ACTION_DELTAS)  # a power of two: exact; sums differ in rounding
        targets = [index[target] for target in self.target_cells]
        # One row per target: where the walk may be, having not yet reached that target;
        # the last column is the padding's, always 0.
        alive = np.zeros((len(targets), len(cells) + 1))
        alive[:, index[self.start]] = 1.0
        rows = np.arange(len(targets))
        while True:
            yield float(1.0 - alive.sum(axis=1).mean())
            alive[:, :-1] = alive[:, comes_from].sum(axis=2) * share
            alive[rows, targets] = 0.0


def step_reward(
    arrived: bool, stayed: bool = False, step_penalty: float = 0.0, bump_penalty: float = 0.0
) -> float:
    """The reward of one robot's step; the step terminates its episode if ``arrived``.

    :data:`TARGET_REWARD` on the step the robot reaches its package, else 0.0,
    less ``step_penalty`` on every step that does not reach it and less
    ``bump_penalty`` when a wall or shelf refused the move (``stayed``). Every
    environment takes its rewards from here; :func:`warehouse_phys.world.batched.step_rewards`
    is the same rule for many robots at once (equal, as a test proves).
    """
    reward = TARGET_REWARD if arrived else 0.0
    if not arrived:
        reward -= step_penalty
    if stayed:
        reward -= bump_penalty
    return reward


#: Largest floor given a move table by :func:`move_table` [cells].
MOVE_TABLE_CELLS = 4096


@functools.lru_cache(maxsize=64)
def _move_table(grid_key: tuple) -> list[list[tuple[Cell, ...]]] | None:
    rows, cols, layout = grid_key
    grid = WarehouseGrid(rows, cols) if layout is None else WarehouseGrid.from_layout(layout)
    return [
        [tuple(grid.move((r, c), action) for action in range(len(ACTION_DELTAS)))
         for c in range(cols)]
        for r in range(rows)
    ]  # fmt: skip


def move_table(grid: WarehouseGrid) -> list[list[tuple[Cell, ...]]] | None:
    """``grid.move`` for every cell and action, as ``table[row][col][action]``.

    One look-up instead of a call: the grid twin's step uses it. Floors of
    the same size and layout share one table; floors of more than
    :data:`MOVE_TABLE_CELLS` cells get ``None`` (the table would cost more
    memory than it saves time).
    """
    if grid.rows * grid.cols > MOVE_TABLE_CELLS:
        return None
    return _move_table((grid.rows, grid.cols, grid.layout))


def refuse_durations(**arguments: object) -> None:
    """Refuse a ``numpy.timedelta64`` given as a count, which numpy counts as an integer.

    Raises:
        TypeError: naming the first such argument.
    """
    for name, value in arguments.items():
        if isinstance(value, np.timedelta64):
            raise TypeError(f"{name} must be an integer, got {value!r} (timedelta64)")


__all__ = [
    "ACTION_DELTAS",
    "DEFAULT_COLS",
    "DEFAULT_ROWS",
    "DISTANCE_CACHE_CELLS",
    "FLOOR",
    "LAYOUT_SYMBOLS",
    "LISTED_CELLS",
    "MAX_SIDE",
    "MIN_SIDE",
    "MOVE_TABLE_CELLS",
    "PACKAGE",
    "SHELF",
    "START",
    "START_CELL",
    "TARGET_REWARD",
    "Action",
    "Cell",
    "WarehouseGrid",
    "check_size",
    "move_table",
    "refuse_durations",
    "step_reward",
]
