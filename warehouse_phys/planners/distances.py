"""Distances to goals for fleets of thousands on floors of millions of cells, in bounded memory.

A fleet asks, every step, how far each robot is from its package (``info["optimal_steps"]``)
and a planner how far each of a robot's neighbouring cells is. :class:`DistanceMaps`
answers both, two ways:

- **Full maps** while they fit. For each goal asked about, the fewest moves from every
  free cell to it: the same numbers as
  :meth:`warehouse_phys.world.grid.WarehouseGrid.distance_map`, from a breadth-first search
  compiled by Numba (:mod:`warehouse_phys.planners.graph_search`; a 38,586-cell floor's map in
  about half a millisecond). Maps live in one ``uint16`` array, a row per goal and a column
  per free cell, so a batch of look-ups is one gather; the rows are a cache that never
  takes more than ``max_bytes``, evicting the least recently used maps of goals that the
  request at hand does not ask for (no live robot needs them: every robot's goal is asked
  for every step).
- **Guide paths** beyond that. One full map of the field's 1,912 x 1,800 floor (2.2
  million free cells) takes 4.4 MB and 50 ms, so 10,000 robots' maps would take 44 GB and
  minutes. A goal that finds no room keeps instead one path to it from its robot's cell,
  found by A* (weighted :data:`GUIDE_PATH_WEIGHT`: at most that many times the shortest,
  2.4 % longer on average on random floors, for a fifth of the exact search's work; its
  heuristic sees walls through :data:`GUIDE_LANDMARKS` landmarks) and stored as its cells
  (4 bytes a move). A cell on the path is answered with the moves left along it; a
  neighbour of the robot beside the path with one more than the path cell beside it. A
  robot pushed one move off its path rejoins it there (one move, then the old path); one
  farther away gets a new path from where it stands. These are upper bounds on the true
  distance, with its parity, so a planner still ranks the path's next cell first. Paths
  of goals not asked for lately are dropped.

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame. Cells are numbered row by row, ``index = row * cols + col``.
"""

from __future__ import annotations

from types import ModuleType

import numpy as np

from warehouse_phys.world.floor_regions import label_regions
from warehouse_phys.world.grid import WarehouseGrid

#: The distance of a cell that cannot reach the goal, and of a shelf cell [moves].
UNREACHABLE = 65535
#: Most memory the full maps of one :class:`DistanceMaps` may hold [bytes]: 900 MiB, room
#: for the 10,000 maps of 10,000 robots' packages on a 38,586-cell floor (736 MiB).
DEFAULT_MAX_BYTES = 900 * 2**20
#: A guide path is at most this many times the shortest path (A*'s weight on its
#: Manhattan heuristic, in sixteenths: 17 / 16).
GUIDE_PATH_WEIGHT = 17 / 16
#: How many cells either side of where a robot last stood on its guide path a look-up
#: searches [cells]: a robot moves one cell a step, its neighbours lie within two.
GUIDE_WINDOW = 4
#: Landmarks of the guide paths' A* (:func:`~warehouse_phys.planners.graph_search.estimate`):
#: full maps from this many cells spread over the floor, built at the first guided goal
#: [maps], 2 bytes a cell each. Where walls are large they cut a path's search
#: severalfold (orz900d: 3.9 ms to 0.5 ms; scene_mp_2p_01: 8.8 ms to 2.0 ms; 32 did no
#: better); on scattered obstacles they neither help nor cost.
GUIDE_LANDMARKS = 16
#: A guide path not asked for in this many requests is dropped when room is needed
#: [requests]: a fleet's step makes a few.
GUIDE_STALE_REQUESTS = 64


def _graph_search() -> ModuleType:
    """The compiled searches, imported at first use: only shelved floors need Numba."""
    from warehouse_phys.planners import graph_search

    return graph_search


class DistanceMaps:
    """Shortest-path distances (moves) from cells to goal cells of one floor, bounded.

    ``lookup(cells, goals)`` gives, for each position, the moves from ``cells[i]`` to
    ``goals[i]`` (cell indices ``row * cols + col``), or :data:`UNREACHABLE` when no path
    exists or the cell is a shelf.

    - A goal with a **full map** (the module's docstring) gets exactly
      ``grid.distance_map(goal)`` (with :data:`UNREACHABLE` for its ``-1``). A request's
      goals get full maps while the maps fit in ``max_bytes`` (each takes
      ``2 * (free cells + 1)`` bytes), evicting the least recently used maps of goals the
      request does not ask for; :meth:`prepare` builds many at once.
    - A goal beyond that room is **guided**: its answers are upper bounds, within
      :data:`GUIDE_PATH_WEIGHT` of the truth on the path, from one stored path per goal.
      In each request the queries of one goal are a group, and the cell beside most of the
      group's others (a robot's own cell among its neighbours) is its *centre*: the path
      runs from there, and is found anew when the centre is off it. :attr:`guided` counts
      these goals and :attr:`path_bytes` their memory.

    On a floor without shelves the distance is the Manhattan distance, computed on the
    fly: no map or path is kept.

    Distances are kept in 16 bits: a goal with a cell more than 65,534 moves away (only a
    snake-like maze of more than 65,534 cells has one) is refused with a ``ValueError``
    when its map or path is built, never wrapped around.

    Raises:
        TypeError: if ``grid`` is not a :class:`~warehouse_phys.world.grid.WarehouseGrid`.
        ValueError: if ``max_bytes`` is not a positive integer large enough for one map.
    """

    def __init__(self, grid: WarehouseGrid, *, max_bytes: int = DEFAULT_MAX_BYTES) -> None:
        if not isinstance(grid, WarehouseGrid):
            raise TypeError(f"grid must be a WarehouseGrid, got {type(grid).__name__}")
        if isinstance(max_bytes, bool) or not isinstance(max_bytes, (int, np.integer)):
            raise TypeError(f"max_bytes must be an integer, got {max_bytes!r}")
        self.grid = grid
        #: No shelves: every distance is the Manhattan distance, no map needed.
        self._open_floor = not grid.shelf_mask.any()
        rows, cols = grid.rows, grid.cols
        self.n_cells = rows * cols
        free = grid.free_mask
        free_cells = np.flatnonzero(free.reshape(-1))
        n_free = self._n_free = len(free_cells)
        #: The column of every cell in a map: its rank among the free cells, or the last
        #: column (always :data:`UNREACHABLE`) for a shelf.
        self._column = np.full(self.n_cells, n_free, dtype=np.int32)
        self._column[free_cells] = np.arange(n_free, dtype=np.int32)
        self._map_bytes = 2 * (n_free + 1)
        if max_bytes < self._map_bytes:
            raise ValueError(
                f"max_bytes={max_bytes} cannot hold one distance map of this floor "
                f"({self._map_bytes} bytes)"
            )
        self.max_bytes = int(max_bytes)
        self._max_maps = self.max_bytes // self._map_bytes
        self._table = np.empty((0, n_free + 1), dtype=np.uint16)
        #: The table row of each goal cell's map, -1 where none is kept.
        self._row_of_goal = np.full(self.n_cells, -1, dtype=np.int32)
        #: The goal cell each table row holds, -1 where free.
        self._goal_of_row = np.empty(0, dtype=np.int64)
        #: When each row was last asked for (a request counter), for the LRU eviction.
        self._last_used = np.empty(0, dtype=np.int64)
        self._requests = 0
        if not self._open_floor:
            self._build_search(free, free_cells)

    def _build_search(self, free: np.ndarray, free_cells: np.ndarray) -> None:
        """The move graph, the regions and the guide paths' storage (a few bytes a cell)."""
        self._graph = _graph_search().move_graph(free)
        cell_row, cell_col = np.divmod(free_cells, self.grid.cols)
        self._cell_row, self._cell_col = cell_row.astype(np.int32), cell_col.astype(np.int32)
        labels, _ = label_regions(free)  # regions connected by moves (4-connectivity)
        self._region = labels.reshape(-1)[free_cells].astype(np.int32)
        self._scratch = np.zeros((self._n_free, 4), dtype=np.int32)
        self._generation = 0
        self._path = np.empty(self._n_free, dtype=np.int32)
        #: Guide paths: slot s's cells are pool[start[s] : start[s] + moves[s] + 1].
        self._slot_of_goal = np.full(self.n_cells, -1, dtype=np.int32)
        self._slot_goal = np.empty(0, dtype=np.int64)
        self._path_start = np.empty(0, dtype=np.int64)
        self._path_moves = np.empty(0, dtype=np.int64)
        self._cursor = np.empty(0, dtype=np.int64)
        self._slot_used = np.empty(0, dtype=np.int64)
        self._pool = np.empty(1 << 12, dtype=np.int32)
        self._pool_used = 0
        self._landmarks: np.ndarray | None = None  # built at the first guided goal

    @property
    def maps(self) -> int:
        """How many goals' full maps are kept now."""
        return int((self._goal_of_row >= 0).sum())

    @property
    def guided(self) -> int:
        """How many goals are guided by a stored path now (goals beyond the maps' room)."""
        return 0 if self._open_floor else int((self._path_moves >= 0).sum())

    @property
    def nbytes(self) -> int:
        """The memory the full maps take now [bytes]: every row a map was ever built in
        (rows of evicted maps are reused), at most ``max_bytes``."""
        return len(self._goal_of_row) * self._map_bytes

    @property
    def path_bytes(self) -> int:
        """The memory the guide paths take now [bytes]: their cells' storage (4 bytes a
        cell, at most twice the live paths' cells) and 40 bytes a guided goal."""
        return 0 if self._open_floor else self._pool.nbytes + 40 * len(self._slot_goal)

    @property
    def open_floor(self) -> bool:
        """Whether the floor has no shelf: every distance is then the Manhattan distance,
        and no map is built."""
        return self._open_floor

    def prepare(self, goals: np.ndarray) -> None:
        """Build the full maps of the goals in ``goals`` (cell indices) that are missing, as
        many as ``max_bytes`` has room for (evicting the least recently used maps of other
        goals); the rest are guided when asked about.

        Raises:
            ValueError: if a goal is off the floor or a shelf.
        """
        goals = np.asarray(goals, dtype=np.int64).reshape(-1)
        self._check_goals(goals)
        if not self._open_floor and goals.size:
            self._mapped(goals)

    def lookup(self, cells: np.ndarray, goals: np.ndarray) -> np.ndarray:
        """The moves from each of ``cells`` to the goal at the same position (cell
        indices, arrays of one shape), int64, :data:`UNREACHABLE` where there is no path:
        exact for goals with full maps, upper bounds for guided ones (the class docstring).

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
        self._check_goals(goals)
        if self._open_floor:
            cell_row, cell_col = np.divmod(cells, self.grid.cols)
            goal_row, goal_col = np.divmod(goals, self.grid.cols)
            return np.abs(cell_row - goal_row) + np.abs(cell_col - goal_col)
        flat_cells, flat_goals = cells.reshape(-1), goals.reshape(-1)
        out = np.empty(flat_cells.size, dtype=np.int64)
        if flat_cells.size:
            mapped = self._mapped(flat_goals)
            rows = self._row_of_goal[flat_goals[mapped]]
            out[mapped] = self._table[rows, self._column[flat_cells[mapped]]]
            if not mapped.all():
                out[~mapped] = self._guided(flat_cells[~mapped], flat_goals[~mapped], True)
        return out.reshape(cells.shape)

    def distance(self, cell: int, goal: int) -> int:
        """The moves from one ``cell`` to one ``goal`` (cell indices): what :meth:`lookup`
        gives, at the cost of a few index operations when the goal has a full map (a
        planner asks this thousands of times a step). A guided goal's path stays where it
        is: the cell is answered on it, beside it, or by a search of its own."""
        if self._open_floor or not 0 <= goal < self.n_cells or not 0 <= cell < self.n_cells:
            return int(self.lookup(np.array([cell]), np.array([goal]))[0])
        row = int(self._row_of_goal[goal])
        if row >= 0:
            return int(self._table[row, self._column[cell]])
        self._check_goals(np.array([goal]))
        return int(self._guided(np.array([cell]), np.array([goal]), False)[0])

    def _check_goals(self, goals: np.ndarray) -> None:
        if goals.size and (goals.min() < 0 or goals.max() >= self.n_cells):
            raise ValueError(f"goals must be cell indices 0..{self.n_cells - 1} of this floor")
        if self._open_floor or not goals.size:
            return
        shelves = goals[self._column[goals] == self._n_free]
        if shelves.size:
            cols = self.grid.cols
            raise ValueError(
                f"goal cell {(int(shelves[0]) // cols, int(shelves[0]) % cols)} is a shelf"
            )

    def _mapped(self, goals: np.ndarray) -> np.ndarray:
        """Whether each of ``goals`` has a full map, after building the missing ones that
        the table has room for (free rows, or rows of goals not in ``goals``)."""
        self._requests += 1
        asked = np.unique(goals)
        missing = asked[self._row_of_goal[asked] < 0]
        if missing.size:
            in_use = int((self._row_of_goal[asked] >= 0).sum())
            room = self._max_maps - in_use
            if room > 0:
                self._compute(missing[:room], keep=asked)
        rows = self._row_of_goal[asked]
        self._last_used[rows[rows >= 0]] = self._requests
        return self._row_of_goal[goals] >= 0

    def _compute(self, missing: np.ndarray, keep: np.ndarray) -> None:
        """Compute the maps of the goals ``missing`` into free or evicted rows, never
        evicting the maps of the goals in ``keep``."""
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
        rows = free_rows[: len(missing)]
        deep = _graph_search().fill_distance_rows(
            self._graph, self._column[missing], self._table, rows, _distance_limit()
        )
        done = len(missing) if deep < 0 else deep
        self._goal_of_row[rows[:done]] = missing[:done]
        self._row_of_goal[missing[:done]] = rows[:done]
        if deep >= 0:
            raise _too_deep(int(missing[deep]), self.grid.cols)

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

    def __getstate__(self) -> dict[str, object]:
        """What a pickle keeps: the maps' table up to the rows handed out so far (in use
        or freed), not the address space reserved for all of ``max_bytes`` (reading it
        would commit it)."""
        state = self.__dict__.copy()
        state["_table"] = self._table[: len(self._goal_of_row)]
        state["_table_rows"] = len(self._table)
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        """The pickled maps back in a table reserved as :meth:`_grow` reserves it (the
        rows read and their copy are both in memory for a moment)."""
        rows = state.pop("_table_rows")
        kept = state["_table"]
        state["_table"] = np.empty((rows, kept.shape[1]), dtype=kept.dtype)
        state["_table"][: len(kept)] = kept
        self.__dict__.update(state)

    def _guided(self, cells: np.ndarray, goals: np.ndarray, centred: bool) -> np.ndarray:
        """Guided answers for ``cells`` towards ``goals`` (goals without full maps): with
        ``centred``, each goal's group has a centre that its path must run through."""
        search = _graph_search()
        columns = self._column[cells]
        out = np.full(cells.size, UNREACHABLE, dtype=np.int64)
        goal_columns = self._column[goals]
        reach = columns < self._n_free  # a shelf cell reaches nothing
        reach[reach] = self._region[columns[reach]] == self._region[goal_columns[reach]]
        if not reach.any():
            return out
        cells, goals, columns = cells[reach], goals[reach], columns[reach]
        slots = self._slots_of(goals)
        rows, cols = np.divmod(cells, self.grid.cols)
        centre = search.group_centres(slots, rows, cols) if centred else np.zeros(len(slots), bool)
        answers = np.empty(len(slots), dtype=np.int64)
        for attempt in range(2):  # the second pass reads the new paths
            search.guided_pass(columns, rows, cols, slots, centre, self._pool, self._path_start,
                               self._path_moves, self._cursor, self._cell_row, self._cell_col,
                               GUIDE_WINDOW, answers)  # fmt: skip
            renew = answers == search.NEEDS_NEW_PATH
            if attempt or not renew.any():
                break
            # A path from each such goal's centre (or, without one, its first query).
            which = np.flatnonzero(renew)
            which = which[np.lexsort((~centre[which], slots[which]))]
            which = which[np.unique(slots[which], return_index=True)[1]]
            for slot, column in zip(slots[which].tolist(), columns[which].tolist(), strict=True):
                self._store_path(slot, column)
            centre[renew] = False  # on their new paths now
        for i in np.flatnonzero(answers < 0).tolist():  # far from the path: a search of its own
            answers[i] = self._path_from(int(columns[i]), int(self._column[goals[i]]))
        out[reach] = answers
        return out

    def _slots_of(self, goals: np.ndarray) -> np.ndarray:
        """The guide-path slot of each goal, opening slots (without a path) for new ones."""
        recent = self._slot_used > self._requests - GUIDE_STALE_REQUESTS
        if len(recent) > 2 * int(recent.sum()) + 1024:
            self._recycle(recent)
        slots = self._slot_of_goal[goals]
        new = np.unique(goals[slots < 0])
        if new.size:
            first = len(self._slot_goal)
            self._slot_of_goal[new] = np.arange(first, first + len(new), dtype=np.int32)
            self._slot_goal = np.concatenate([self._slot_goal, new])
            none = np.full(len(new), -1, dtype=np.int64)
            self._path_start = np.concatenate([self._path_start, none])
            self._path_moves = np.concatenate([self._path_moves, none])
            self._cursor = np.concatenate([self._cursor, np.zeros(len(new), np.int64)])
            self._slot_used = np.concatenate([self._slot_used, np.zeros(len(new), np.int64)])
            slots = self._slot_of_goal[goals]
        self._slot_used[slots] = self._requests
        return slots.astype(np.int64)

    def _path_from(self, column: int, goal_column: int) -> int:
        """A guide path's moves from ``column`` to ``goal_column`` (same region), left in
        ``self._path``."""
        self._generation += 1
        if self._generation >= 2**31 - 1:  # the scratch's generation stamps wrap: clear
            self._scratch[:, [0, 3]] = 0
            self._generation = 1
        if self._landmarks is None:
            self._landmarks = self._choose_landmarks()
        moves = int(_graph_search().shortest_path(
            self._graph, self._cell_row, self._cell_col, column, goal_column, self._scratch,
            self._generation, self._path, self._landmarks,
            round(16 * GUIDE_PATH_WEIGHT)))  # fmt: skip
        if moves >= _distance_limit():
            raise _too_deep(int(np.flatnonzero(self._column == goal_column)[0]), self.grid.cols)
        return moves

    def _choose_landmarks(self) -> np.ndarray:
        """:data:`GUIDE_LANDMARKS` full maps from cells of the floor's largest region (where
        most goals are), spread out by farthest-point selection (each the cell farthest
        from those chosen), as ``(k, free cells + 1)`` uint16 rows."""
        count = min(GUIDE_LANDMARKS, self._n_free)
        table = np.empty((count, self._n_free + 1), dtype=np.uint16)
        rows = np.arange(count)
        largest = self._region == np.argmax(np.bincount(self._region))
        # Cells of other regions count as chosen already: no landmark lands on an island.
        nearest = np.where(largest, UNREACHABLE, 0).astype(np.uint16)
        start = int(np.argmax(largest))  # then the cell farthest from it comes first
        _graph_search().fill_distance_rows(self._graph, np.array([start]), table, rows[:1])
        chosen = int(np.argmax(np.where(largest, table[0, :-1], 0)))
        for k in range(count):
            deep = _graph_search().fill_distance_rows(
                self._graph, np.array([chosen]), table, rows[k : k + 1], _distance_limit()
            )
            if deep >= 0:  # too deep for 16 bits: the landmarks so far will do
                return table[:k]
            np.minimum(nearest, table[k, :-1], out=nearest)
            chosen = int(np.argmax(nearest))
        return table

    def _store_path(self, slot: int, column: int) -> None:
        """A new guide path for ``slot`` from ``column``, its robot's cell: the old path
        from where it passes beside the cell, one move away (a robot pushed aside), else a
        new search."""
        rejoin = self._beside_path(slot, column)
        if rejoin >= 0:
            start, old = int(self._path_start[slot]), int(self._path_moves[slot])
            moves = 1 + old - rejoin
            self._path[0] = column
            self._path[1 : moves + 1] = self._pool[start + rejoin : start + old + 1]
        else:
            moves = self._path_from(column, int(self._column[self._slot_goal[slot]]))
        if self._pool_used + moves + 1 > len(self._pool):
            self._compact(moves + 1)
        self._pool[self._pool_used : self._pool_used + moves + 1] = self._path[: moves + 1]
        self._path_start[slot] = self._pool_used
        self._path_moves[slot] = moves
        self._cursor[slot] = 0
        self._pool_used += moves + 1

    def _beside_path(self, slot: int, column: int) -> int:
        """The furthest position along ``slot``'s path, within :data:`GUIDE_WINDOW` of its
        cursor, of a cell one move from ``column``; -1 if none (or no path)."""
        moves = int(self._path_moves[slot])
        if moves < 0:
            return -1
        start, here = int(self._path_start[slot]), int(self._cursor[slot])
        first = max(0, here - GUIDE_WINDOW)
        window = self._pool[start + first : start + min(moves, here + GUIDE_WINDOW) + 1]
        apart = np.abs(self._cell_row[window] - self._cell_row[column]) + np.abs(
            self._cell_col[window] - self._cell_col[column]
        )
        beside = np.flatnonzero(apart == 1)
        return first + int(beside[-1]) if beside.size else -1

    def _recycle(self, keep: np.ndarray) -> None:
        """Close the slots of goals not in ``keep`` (not asked for lately), so that the
        slots' memory follows the fleet, not every goal it ever had."""
        self._slot_of_goal[self._slot_goal[~keep]] = -1
        self._slot_of_goal[self._slot_goal[keep]] = np.arange(int(keep.sum()), dtype=np.int32)
        for name in ("_slot_goal", "_path_start", "_path_moves", "_cursor", "_slot_used"):
            setattr(self, name, getattr(self, name)[keep])
        self._compact(0)

    def _compact(self, needed: int) -> None:
        """Room for ``needed`` more path cells: drop the paths of goals not asked for in
        :data:`GUIDE_STALE_REQUESTS` requests, pack the rest, and grow if still short."""
        live = (self._path_moves >= 0) & (self._slot_used > self._requests - GUIDE_STALE_REQUESTS)
        self._path_moves[~live] = -1
        lengths = np.where(live, self._path_moves + 1, 0)
        total = int(lengths.sum())
        capacity = len(self._pool)
        while capacity < 2 * (total + needed):
            capacity *= 2
        pool = np.empty(capacity, dtype=np.int32)
        starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
        for slot in np.flatnonzero(live).tolist():
            old, size = int(self._path_start[slot]), int(lengths[slot])
            pool[starts[slot] : starts[slot] + size] = self._pool[old : old + size]
        self._path_start = np.where(live, starts, -1)
        self._pool, self._pool_used = pool, total


def _distance_limit() -> int:
    """The first distance 16 bits cannot hold apart from :data:`UNREACHABLE` itself (read
    at each call, so that a test can lower it)."""
    return UNREACHABLE


def _too_deep(goal: int, cols: int) -> ValueError:
    return ValueError(
        f"a shortest path to {divmod(goal, cols)} is longer than these 16-bit maps hold "
        f"({UNREACHABLE - 1} moves)"
    )
