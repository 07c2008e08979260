"""Distances to packages for fleets of thousands: one map per goal, computed fast, kept bounded.

A fleet asks, every step, how far each robot is from its package (``info["optimal_steps"]``)
and a planner how far each of a robot's neighbouring cells is. :class:`DistanceMaps` keeps,
for every goal cell asked about, the fewest moves from every free cell to it: the same
numbers as :meth:`warehouse_phys.rules.grid.WarehouseGrid.distance_map`, found by a breadth-first
search over the same moves, run in C by SciPy so that 10,000 maps of a 38,586-cell floor
take seconds rather than minutes. Maps live in one ``uint16`` array with a row per goal and a
column per free cell (shelves need none), so a batch of look-ups is one array gather; the
rows are a least-recently-used cache whose size never exceeds ``max_bytes``.

Like :mod:`warehouse_phys.rules.grid`, this module imports neither gymnasium, pymunk nor pygame.
Cells are numbered row by row, ``index = row * cols + col``.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import breadth_first_order

from warehouse_phys.rules.grid import ACTION_DELTAS, WarehouseGrid

#: The distance of a cell that cannot reach the goal, and of a shelf cell [moves].
UNREACHABLE = int(np.iinfo(np.uint16).max)
#: Most memory the maps of one :class:`DistanceMaps` may hold [bytes]: 900 MiB, room for
#: the 10,000 maps of 10,000 robots' packages on a 38,586-cell floor (736 MiB).
DEFAULT_MAX_BYTES = 900 * 2**20


class DistanceMaps:
    """Exact shortest-path distances (moves) from every cell to goal cells of one floor.

    ``lookup(cells, goals)`` gives, for each position, the fewest moves from ``cells[i]``
    to ``goals[i]`` (cell indices ``row * cols + col``), or :data:`UNREACHABLE` when no
    path exists or the cell is a shelf: exactly ``grid.distance_map(goal)`` (with
    :data:`UNREACHABLE` for its ``-1``). The map of a goal is computed the first time the
    goal is asked about (:meth:`prepare` computes many at once) and kept until room is
    needed for others: the least recently used go first, and the maps never take more
    than ``max_bytes`` (each takes ``2 * (free cells + 1)`` bytes). A single request for
    more goals than fit is refused with a ``ValueError`` that names ``max_bytes``.

    On a floor without shelves the distance is the Manhattan distance, computed on the
    fly: no map is built or kept.

    Distances are kept in 16 bits: a goal whose map would hold a shortest path longer
    than 65,534 moves (only a snake-like maze of more than 65,534 cells has one) is
    refused with a ``ValueError`` when its map is built, never wrapped around.

    Raises:
        TypeError: if ``grid`` is not a :class:`~warehouse_phys.rules.grid.WarehouseGrid`.
        ValueError: if ``max_bytes`` is not a positive integer large enough for one map.
    """

    def __init__(self, grid: WarehouseGrid, *, max_bytes: int = DEFAULT_MAX_BYTES) -> None:
        if not isinstance(grid, WarehouseGrid):
            raise TypeError(f"grid must be a WarehouseGrid, got {type(grid).__name__}")
        if isinstance(max_bytes, bool) or not isinstance(max_bytes, (int, np.integer)):
            raise TypeError(f"max_bytes must be an integer, got {max_bytes!r}")
        self.grid = grid
        #: No shelves: every distance is the Manhattan distance, no map needed.
        self._open_floor = not grid.shelves
        rows, cols = grid.rows, grid.cols
        self.n_cells = rows * cols
        free = np.ones(self.n_cells, dtype=bool)
        if grid.shelves:
            shelves = np.array(sorted(grid.shelves), dtype=np.int64).reshape(-1, 2)
            free[shelves[:, 0] * cols + shelves[:, 1]] = False
        free_cells = np.flatnonzero(free)
        n_free = self._n_free = len(free_cells)
        #: The column of every cell in a map: its rank among the free cells, or the last
        #: column (always :data:`UNREACHABLE`) for a shelf.
        self._column = np.full(self.n_cells, n_free, dtype=np.int64)
        self._column[free_cells] = np.arange(n_free)
        self._map_bytes = 2 * (n_free + 1)
        if max_bytes < self._map_bytes:
            raise ValueError(
                f"max_bytes={max_bytes} cannot hold one distance map of this floor "
                f"({self._map_bytes} bytes)"
            )
        self.max_bytes = int(max_bytes)
        self._max_maps = self.max_bytes // self._map_bytes
        self._graph = _move_graph(free_cells, self._column, rows, cols)
        self._table = np.empty((0, n_free + 1), dtype=np.uint16)
        #: The table row of each goal cell's map, -1 where none is kept.
        self._row_of_goal = np.full(self.n_cells, -1, dtype=np.int64)
        #: The goal cell each table row holds, -1 where free.
        self._goal_of_row = np.empty(0, dtype=np.int64)
        #: When each row was last asked for (a request counter), for the LRU eviction.
        self._last_used = np.empty(0, dtype=np.int64)
        self._requests = 0

    @property
    def maps(self) -> int:
        """How many goals' maps are kept now."""
        return int((self._goal_of_row >= 0).sum())

    @property
    def nbytes(self) -> int:
        """The memory the maps take now [bytes]: every row a map was ever built in (rows
        of evicted maps are reused), at most ``max_bytes``."""
        return len(self._goal_of_row) * self._map_bytes

    @property
    def open_floor(self) -> bool:
        """Whether the floor has no shelf: every distance is then the Manhattan distance,
        and no map is built."""
        return self._open_floor

    def prepare(self, goals: np.ndarray) -> None:
        """Make sure the map of every goal in ``goals`` (cell indices) is kept; computes the
        missing ones, evicting the least recently used maps of other goals if needed.

        Raises:
            ValueError: if a goal is off the floor or a shelf, or ``goals`` holds more
                distinct goals than ``max_bytes`` has room for.
        """
        self._rows_of(np.asarray(goals, dtype=np.int64).reshape(-1))

    def lookup(self, cells: np.ndarray, goals: np.ndarray) -> np.ndarray:
        """The fewest moves from each of ``cells`` to the goal at the same position (cell
        indices, arrays of one shape), int64, :data:`UNREACHABLE` where there is no path.

        Raises:
            ValueError: as :meth:`prepare`, for a cell off the floor, or for arrays of
                different shapes.
        """
        cells = np.asarray(cells, dtype=np.int64)
        goals = np.asarray(goals, dtype=np.int64)
        if cells.shape != goals.shape:
            raise ValueError(f"cells {cells.shape} and goals {goals.shape} differ in shape")
        if cells.size and (cells.min() < 0 or cells.max() >= self.n_cells):
            raise ValueError(f"cells must be indices 0..{self.n_cells - 1} of this floor")
        if self._open_floor:
            self._check_goals(goals)
            cell_row, cell_col = np.divmod(cells, self.grid.cols)
            goal_row, goal_col = np.divmod(goals, self.grid.cols)
            return np.abs(cell_row - goal_row) + np.abs(cell_col - goal_col)
        rows = self._rows_of(goals.reshape(-1))
        return (
            self._table[rows, self._column[cells.reshape(-1)]].astype(np.int64).reshape(cells.shape)
        )

    def distance(self, cell: int, goal: int) -> int:
        """The fewest moves from one ``cell`` to one ``goal`` (cell indices): what
        :meth:`lookup` gives, at the cost of a few index operations when the goal's map is
        kept (a planner asks this thousands of times a step)."""
        if self._open_floor or not 0 <= goal < self.n_cells or not 0 <= cell < self.n_cells:
            return int(self.lookup(np.array([cell]), np.array([goal]))[0])
        row = int(self._row_of_goal[goal])
        if row < 0:
            return int(self.lookup(np.array([cell]), np.array([goal]))[0])
        return int(self._table[row, self._column[cell]])

    def _check_goals(self, goals: np.ndarray) -> None:
        if goals.size and (goals.min() < 0 or goals.max() >= self.n_cells):
            raise ValueError(f"goals must be cell indices 0..{self.n_cells - 1} of this floor")

    def _rows_of(self, goals: np.ndarray) -> np.ndarray:
        """The table row of each goal's map, computing the missing maps first."""
        if goals.size == 0:
            return np.empty(0, dtype=np.int64)
        self._check_goals(goals)
        if self._open_floor:
            return np.empty(0, dtype=np.int64)
        rows = self._row_of_goal[goals]
        if (rows < 0).any():
            missing = np.unique(goals[rows < 0])
            shelves = missing[self._column[missing] == self._n_free]
            if shelves.size:
                cols = self.grid.cols
                raise ValueError(
                    f"goal cell {(int(shelves[0]) // cols, int(shelves[0]) % cols)} is a shelf"
                )
            self._compute(missing, keep=goals)
            rows = self._row_of_goal[goals]
        self._requests += 1
        self._last_used[rows] = self._requests
        return rows

    def _compute(self, missing: np.ndarray, keep: np.ndarray) -> None:
        """Compute the maps of the goals ``missing`` into free or evicted rows, never
        evicting the maps of the goals in ``keep``."""
        needed = len(np.unique(keep))
        if needed > self._max_maps:
            raise ValueError(
                f"{needed} distinct goals need {needed * self._map_bytes} bytes of distance "
                f"maps; max_bytes={self.max_bytes} holds {self._max_maps}"
            )
        free_rows = np.flatnonzero(self._goal_of_row < 0)
        if len(free_rows) < len(missing):
            capacity = len(self._goal_of_row)
            grown = min(self._max_maps, max(2 * capacity, capacity + len(missing) - len(free_rows)))
            if grown > capacity:
                self._grow(grown)
                free_rows = np.flatnonzero(self._goal_of_row < 0)
        if len(free_rows) < len(missing):
            # Evict the least recently used maps of goals not asked for now.
            kept = np.zeros(len(self._goal_of_row), dtype=bool)
            kept[self._row_of_goal[keep][self._row_of_goal[keep] >= 0]] = True
            candidates = np.flatnonzero((self._goal_of_row >= 0) & ~kept)
            shortfall = len(missing) - len(free_rows)
            oldest = candidates[np.argsort(self._last_used[candidates], kind="stable")[:shortfall]]
            self._row_of_goal[self._goal_of_row[oldest]] = -1
            self._goal_of_row[oldest] = -1
            free_rows = np.flatnonzero(self._goal_of_row < 0)
        for goal, row in zip(missing.tolist(), free_rows[: len(missing)].tolist(), strict=True):
            self._table[row, :-1] = self._breadth_first(goal)
            self._table[row, -1] = UNREACHABLE  # the column of every shelf
            self._goal_of_row[row] = goal
            self._row_of_goal[goal] = row

    def _grow(self, capacity: int) -> None:
        """Room for ``capacity`` maps. The table is reserved once for all the maps
        ``max_bytes`` holds, as address space that the system commits only as rows are
        written, so growing never copies the maps already built (copying 900 MiB of them
        cost seconds in a step)."""
        old = len(self._goal_of_row)
        if len(self._table) < self._max_maps:
            self._table = np.empty((self._max_maps, self._table.shape[1]), dtype=np.uint16)
        self._goal_of_row = np.concatenate([self._goal_of_row, np.full(capacity - old, -1)])
        self._last_used = np.concatenate(
            [self._last_used, np.zeros(capacity - old, dtype=np.int64)]
        )

    def _breadth_first(self, goal: int) -> np.ndarray:
        """Moves from every free cell to ``goal`` (by column), :data:`UNREACHABLE` where none.

        SciPy's breadth-first order lists the cells layer by layer, and the position of
        each cell's predecessor never decreases along it, so the layers' bounds follow
        from one binary search each.
        """
        source = int(self._column[goal])
        order, predecessors = breadth_first_order(
            self._graph, source, directed=True, return_predecessors=True
        )
        position = np.empty(self._graph.shape[0], dtype=np.int64)
        position[order] = np.arange(len(order))
        parent_position = position[predecessors[order[1:]]]  # non-decreasing
        bounds = [0, 1]
        while bounds[-1] < len(order):
            # The next layer: every cell whose predecessor lies in the last one.
            bounds.append(int(np.searchsorted(parent_position, bounds[-1])) + 1)
        layers = len(bounds) - 1
        if layers > UNREACHABLE:
            raise ValueError(
                f"a shortest path to {divmod(goal, self.grid.cols)} is {layers - 1} moves "
                f"long, more than these 16-bit maps hold"
            )
        out = np.full(self._graph.shape[0], UNREACHABLE, dtype=np.uint16)
        out[order] = np.repeat(np.arange(layers, dtype=np.uint16), np.diff(bounds))
        return out


def _move_graph(free_cells: np.ndarray, column: np.ndarray, rows: int, cols: int) -> csr_matrix:
    """The floor's moves between free cells as a sparse adjacency matrix over columns."""
    r, c = free_cells // cols, free_cells % cols
    n_free = len(free_cells)
    sources, targets = [], []
    for d_row, d_col in ACTION_DELTAS:
        rr, cc = r + d_row, c + d_col
        inside = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
        neighbour = np.where(inside, rr * cols + cc, 0)
        ok = inside & (column[neighbour] < n_free)
        sources.append(np.flatnonzero(ok))
        targets.append(column[neighbour[ok]])
    source = np.concatenate(sources)
    target = np.concatenate(targets)
    return csr_matrix(
        (np.ones(len(source), dtype=np.int8), (source, target)), shape=(n_free, n_free)
    )
