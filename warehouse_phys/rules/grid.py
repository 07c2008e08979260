"""The pure warehouse world: cells, actions, moves, targets and optimal distances.

Every environment of the package follows these rules, so the grid twin and the
physics-backed environment cannot drift apart. This module imports neither
gymnasium, pymunk nor pygame: only numpy (for the random generator type and the
floor's regions) and, for a layout that marks no start, scipy's region labelling.

Its length is the world model itself, the one source of truth for every twin: split
it and the rules would have two homes.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Iterator, Sequence
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

#: The default floor [cells]: 4 rows of 5 cells, the size every environment starts with.
DEFAULT_ROWS, DEFAULT_COLS = 4, 5

#: Where the robot stands after every reset.
START_CELL = Cell(0, 0)

#: Reward for standing on the target; every other step earns nothing.
TARGET_REWARD = 1.0

#: Fewest rows and columns of a floor [cells]: the target sits outside row 0 and column 0.
MIN_SIDE = 2
#: Most rows and columns of a floor [cells]. The world model keeps a few objects per
#: cell, so memory and build time grow with the area: a 512 x 512 floor builds in
#: well under a second and holds about 100 MB.
MAX_SIDE = 512

#: Distance maps kept for :meth:`WarehouseGrid.optimal_steps`, counted in cells
#: (about 8 bytes each): about 16 MB, whatever the floor.
DISTANCE_CACHE_CELLS = 2**21

#: The symbols of a layout's text, one character per cell.
FLOOR, SHELF, PACKAGE, START = ".", "#", "P", "S"
LAYOUT_SYMBOLS = {
    FLOOR: "floor",
    SHELF: "shelf",
    PACKAGE: "floor where packages may appear",
    START: "a robot's start (floor); the first is the single robot's, a fleet uses all",
}


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
        "cols",
        "layout",
        "reachable",
        "rows",
        "shelves",
        "start",
        "starts",
        "starts_marked",
        "target_cells",
    )

    def __init__(self, rows: int, cols: int) -> None:
        rows = check_size("grid_rows", rows)
        cols = check_size("grid_cols", cols)
        targets = tuple(Cell(r, c) for r in range(1, rows) for c in range(1, cols))
        self._setup(rows, cols, frozenset(), START_CELL, targets, layout=None)

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
        rows = _checked_layout(layout)
        width = len(rows[0])
        starts = [Cell(r, c) for r, row in enumerate(rows) for c, s in enumerate(row) if s == START]
        start = starts[0] if starts else _unmarked_start(rows)
        shelves = frozenset(
            Cell(r, c) for r, row in enumerate(rows) for c, s in enumerate(row) if s == SHELF
        )
        grid = cls.__new__(cls)
        grid._setup(len(rows), width, shelves, start, (), layout=tuple(rows))
        stranded = [tuple(cell) for cell in starts if cell not in grid.reachable]
        if stranded:
            raise ValueError(
                f"start cells {_cell_list(stranded)} cannot be reached from the start "
                f"{tuple(start)}"
            )
        grid.starts = tuple(starts) or (start,)
        grid.starts_marked = bool(starts)
        targets = _package_cells(grid, rows)
        grid.target_cells = targets
        return grid

    def _setup(
        self,
        rows: int,
        cols: int,
        shelves: frozenset[Cell],
        start: Cell,
        target_cells: tuple[Cell, ...],
        *,
        layout: tuple[str, ...] | None,
    ) -> None:
        self.rows = rows
        self.cols = cols
        #: The shelf cells; the robot can never stand on one.
        self.shelves = shelves
        #: Where the robot stands after every reset.
        self.start = start
        #: Every start cell of the layout in reading order, ``start`` first; ``(start,)``
        #: on the empty floor. A fleet puts a robot on each.
        self.starts = (start,)
        #: Whether the start was given: by ``S`` cells of a layout, or as the corner of a
        #: plain floor. False for a layout without ``S`` (a benchmark map, say), whose
        #: start is the first cell of its largest region; a fleet there draws its starts.
        self.starts_marked = True
        #: Every cell the target may be placed on, in row-major order. On the
        #: empty floor: rows 1..R-1 and columns 1..C-1, so never the start's
        #: row or column.
        self.target_cells = target_cells
        #: The layout's text, or ``None`` for the empty floor.
        self.layout = layout
        self._free = [[True] * cols for _ in range(rows)]
        for row, col in shelves:
            self._free[row][col] = False
        self._distances: dict[Cell, list[list[int]]] = {}
        # Each cached distance map holds one entry per cell: keep at most about
        # DISTANCE_CACHE_CELLS entries in all, and at least a few maps.
        self._distance_cache_size = max(4, DISTANCE_CACHE_CELLS // (rows * cols))
        #: Every cell the robot can reach from the start.
        if shelves:
            self.reachable = frozenset(
                Cell(r, c)
                for r, row in enumerate(self._distances_from(start))
                for c, d in enumerate(row)
                if d >= 0
            )
        else:  # an empty floor is connected
            self.reachable = frozenset(Cell(r, c) for r in range(rows) for c in range(cols))

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
        return 0 <= row < self.rows and 0 <= col < self.cols and self._free[row][col]

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
        if exclude is not None and exclude in cells:
            cells = tuple(cell for cell in cells if cell != exclude)
        return cells[int(rng.integers(len(cells)))]

    def optimal_steps(self, cell: tuple[int, int], target: tuple[int, int]) -> int:
        """The fewest actions that take the robot from ``cell`` to ``target``.

        On an empty floor this is the Manhattan distance; around shelves it
        comes from a breadth-first search over the free cells (cached per target).

        Raises:
            ValueError: if ``target`` cannot be reached from ``cell``.
        """
        if not self.shelves:
            return abs(cell[0] - target[0]) + abs(cell[1] - target[1])
        distances = self._distances.get(target)
        if distances is None:
            if len(self._distances) >= self._distance_cache_size:
                del self._distances[next(iter(self._distances))]  # the oldest
            distances = self._distances[Cell(*target)] = self._distances_from(target)
        steps = distances[cell[0]][cell[1]]
        if steps < 0:
            raise ValueError(f"{tuple(target)} cannot be reached from {tuple(cell)}")
        return steps

    def distance_map(self, target: tuple[int, int]) -> list[list[int]]:
        """The fewest moves from every cell to ``target`` (``-1`` where it cannot be
        reached, shelves included), as ``rows`` lists of ``cols`` integers; the
        distances :meth:`optimal_steps` gives. A fresh list."""
        if not self.shelves:
            return [[abs(r - target[0]) + abs(c - target[1]) for c in range(self.cols)]
                    for r in range(self.rows)]  # fmt: skip
        return [list(row) for row in self._distances_from(target)]

    def _distances_from(self, origin: tuple[int, int]) -> list[list[int]]:
        """Moves from ``origin`` to every cell (the same both ways); -1 where it cannot go."""
        rows, cols, free = self.rows, self.cols, self._free
        distances = [[-1] * cols for _ in range(rows)]
        if not self.is_free(origin):
            return distances
        distances[origin[0]][origin[1]] = 0
        frontier, steps = [(origin[0], origin[1])], 0
        while frontier:  # one breadth-first layer at a time
            steps += 1
            reached = []
            for row, col in frontier:
                for r, c in ((row, col - 1), (row + 1, col), (row, col + 1), (row - 1, col)):
                    if 0 <= r < rows and 0 <= c < cols and free[r][c] and distances[r][c] < 0:
                        distances[r][c] = steps
                        reached.append((r, c))
            frontier = reached
        return distances

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
        transition = np.zeros((len(cells), len(cells)))
        for cell in cells:
            for action in range(len(ACTION_DELTAS)):
                transition[index[cell], index[self.move(cell, action)]] += 1 / len(ACTION_DELTAS)
        targets = [index[target] for target in self.target_cells]
        # One row per target: where the walk may be, having not yet reached that target.
        alive = np.zeros((len(targets), len(cells)))
        alive[:, index[self.start]] = 1.0
        rows = np.arange(len(targets))
        while True:
            yield float(1.0 - alive.sum(axis=1).mean())
            alive = alive @ transition
            alive[rows, targets] = 0.0


def step_reward(
    arrived: bool, stayed: bool = False, step_penalty: float = 0.0, bump_penalty: float = 0.0
) -> float:
    """The reward of one robot's step; the step terminates its episode if ``arrived``.

    :data:`TARGET_REWARD` on the step the robot reaches its package, else 0.0,
    less ``step_penalty`` on every step that does not reach it and less
    ``bump_penalty`` when a wall or shelf refused the move (``stayed``). Every
    environment takes its rewards from here; :func:`warehouse_phys.rules.batched.step_rewards`
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


#: Most cells an error message lists; the rest are counted.
LISTED_CELLS = 5


def _checked_layout(layout: Sequence[str]) -> list[str]:
    """The rows of ``layout``, or the ``TypeError``/``ValueError`` of
    :meth:`WarehouseGrid.from_layout` naming what is wrong and where."""
    if isinstance(layout, str) or not isinstance(layout, Sequence):
        raise TypeError(f"a layout is a list of strings, one per row, got {type(layout).__name__}")
    rows = list(layout)
    if not rows or not all(isinstance(row, str) for row in rows):
        raise TypeError("a layout is a non-empty list of strings, one per row")
    width = len(rows[0])
    if width == 0:
        raise ValueError("layout row 0 is empty")
    if len(rows) > MAX_SIDE or width > MAX_SIDE:
        raise ValueError(
            f"the layout has {len(rows)} rows of {width} cells: the largest floor is "
            f"{MAX_SIDE} x {MAX_SIDE} cells"
        )
    for r, row in enumerate(rows):
        if len(row) != width:
            raise ValueError(
                f"layout rows must all have the same length: row {r} has {len(row)} "
                f"cells, row 0 has {width}"
            )
        for c, symbol in enumerate(row):
            if symbol not in LAYOUT_SYMBOLS:
                known = ", ".join(f"{k!r} {v}" for k, v in LAYOUT_SYMBOLS.items())
                raise ValueError(
                    f"unknown layout symbol {symbol!r} at row {r}, column {c}; known: {known}"
                )
    return rows


def _package_cells(grid: WarehouseGrid, rows: Sequence[str]) -> tuple[Cell, ...]:
    """The cells of a layout's floor where packages may appear: its ``P`` cells off the
    starts, or every cell the robot reaches off the starts; refused if there are none."""
    width = len(rows[0])
    start = grid.start
    marked = [Cell(r, c) for r, row in enumerate(rows) for c, s in enumerate(row) if s == PACKAGE]
    if marked:
        unreachable = [tuple(cell) for cell in marked if cell not in grid.reachable]
        if unreachable:
            raise ValueError(
                f"package cells {_cell_list(unreachable)} cannot be reached from the start "
                f"{tuple(start)}"
            )
        targets = tuple(cell for cell in marked if cell not in grid.starts)
    else:
        targets = tuple(
            Cell(r, c)
            for r in range(len(rows))
            for c in range(width)
            if Cell(r, c) in grid.reachable and Cell(r, c) not in grid.starts
        )
    if not targets:
        raise ValueError(
            f"the layout leaves no cell for the package: no floor other than the start "
            f"{tuple(start)} can be reached"
        )
    return targets


def _cell_list(cells: Sequence[tuple[int, int]]) -> str:
    """``cells`` as a list for an error message: the first :data:`LISTED_CELLS`, then how
    many there are in all, so that a message stays one short line on any floor."""
    shown = ", ".join(str(tuple(cell)) for cell in cells[:LISTED_CELLS])
    more = f", ... ({len(cells)} in all)" if len(cells) > LISTED_CELLS else ""
    return f"[{shown}{more}]"


def _unmarked_start(rows: Sequence[str]) -> Cell:
    """The start of a layout that marks none: the first cell, in reading order, of the
    largest region of free cells connected by moves (the first such region on a tie).
    When the layout marks package cells, only the regions holding one compete, and the
    start is the region's first cell that is not a package cell (if it has one)."""
    from scipy.ndimage import label  # imported here: only floors without a start need it

    # Symbols are checked to be ASCII layout symbols, so one byte is one cell.
    symbols = np.frombuffer("".join(rows).encode("ascii"), dtype=np.uint8)
    symbols = symbols.reshape(len(rows), len(rows[0]))
    regions, count = label(symbols != ord(SHELF))  # 4-connected, numbered in reading order
    if count == 0:
        raise ValueError("the layout has no floor: every cell is a shelf")
    sizes = np.bincount(regions.ravel(), minlength=count + 1)
    packages = symbols == ord(PACKAGE)
    candidates = np.unique(regions[packages]) if packages.any() else np.arange(1, count + 1)
    chosen = candidates[int(sizes[candidates].argmax())]  # ascending: the first on a tie
    region = regions.ravel() == chosen
    plain = region & ~packages.ravel()
    first = int(np.flatnonzero(plain if plain.any() else region)[0])
    return Cell(first // len(rows[0]), first % len(rows[0]))


def check_size(name: str, value: object) -> int:
    """``value`` as a number of rows or columns, or a ``TypeError``/``ValueError`` naming ``name``.

    A floor has at least :data:`MIN_SIDE` rows and columns (the target is placed
    outside row 0 and column 0) and at most :data:`MAX_SIDE`.
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    if value < MIN_SIDE:
        raise ValueError(
            f"{name} must be at least {MIN_SIDE}, got {value}: the target is placed in rows "
            "1..R-1 and columns 1..C-1, so a grid needs at least 2 rows and 2 columns"
        )
    if value > MAX_SIDE:
        raise ValueError(
            f"{name} must be at most {MAX_SIDE}, got {value}: the largest floor is "
            f"{MAX_SIDE} x {MAX_SIDE} cells"
        )
    return int(value)


def refuse_durations(**arguments: object) -> None:
    """Refuse a ``numpy.timedelta64`` given as a count, which numpy counts as an integer.

    Raises:
        TypeError: naming the first such argument.
    """
    for name, value in arguments.items():
        if isinstance(value, np.timedelta64):
            raise TypeError(f"{name} must be an integer, got {value!r} (timedelta64)")
