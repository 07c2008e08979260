"""Searches over a floor's moves, compiled: breadth-first distance maps and A* paths.

The distance maps of :mod:`warehouse_phys.planners.distances` need, for thousands of goals, a
breadth-first search over a floor of up to four million cells, and for floors too big to
keep a map per goal, a shortest path per robot. Both are loops over cells whose next step
depends on the last, which array operations can only run one level at a time (one Python
round per level: thousands on a maze). They are compiled here with Numba instead, at C
speed, and cached on disk after the first run. The guidance's guide paths, priced by
traffic, and the flow they make are compiled beside them, over the same move graph and
heap, in :mod:`warehouse_phys.planners.traffic_flow` (whose names still import from here).

The floor is a *move graph*: its free cells numbered ``0..n-1`` (their *columns*, in
reading order), and ``neighbours``, an ``(n, 4)`` int32 array of the column each move
leads to, ``-1`` where the move is blocked. Functions here are pure: they read the graph
and write only the arrays they are given.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

#: The distance of a cell that cannot reach the goal [moves]: the largest uint16.
UNREACHABLE = 65535


def move_graph(free: np.ndarray) -> np.ndarray:
    """The move graph of a floor: ``free`` is its ``(rows, cols)`` boolean mask of free
    cells; the result is ``(n, 4)`` int32, the column each of the four moves (left, down,
    right, up, the grid's action order) leads to from each free cell, ``-1`` where the
    move leaves the floor or enters a shelf."""
    rows, cols = free.shape
    column = np.full(rows * cols, -1, dtype=np.int64)
    cells = np.flatnonzero(free.reshape(-1))
    column[cells] = np.arange(len(cells))
    r, c = np.divmod(cells, cols)
    neighbours = np.full((len(cells), 4), -1, dtype=np.int32)
    for k, (d_row, d_col) in enumerate(((0, -1), (1, 0), (0, 1), (-1, 0))):
        rr, cc = r + d_row, c + d_col
        inside = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
        neighbours[inside, k] = column[rr[inside] * cols + cc[inside]]
    return neighbours


@njit(cache=True, nogil=True)
def fill_distance_rows(
    neighbours: np.ndarray,
    sources: np.ndarray,
    table: np.ndarray,
    rows: np.ndarray,
    limit: int = UNREACHABLE,
) -> int:
    """Breadth-first searches from each of ``sources`` (columns): the moves from every
    cell to ``sources[i]`` are written into ``table[rows[i], :n]`` (uint16), and
    :data:`UNREACHABLE` into the rest of the row (its extra columns and cells that cannot
    reach the source). Returns -1, or the index of the first source from which some cell
    lies ``limit`` moves or more away (its row is then incomplete)."""
    n = neighbours.shape[0]
    queue = np.empty(n, dtype=np.int32)
    for i in range(sources.shape[0]):
        row = table[rows[i]]
        row[:] = UNREACHABLE
        source = sources[i]
        row[source] = 0
        queue[0] = source
        head, tail = 0, 1
        while head < tail:
            cell = queue[head]
            head += 1
            step = np.int64(row[cell]) + 1
            for k in range(4):
                other = neighbours[cell, k]
                if other >= 0 and row[other] == UNREACHABLE:
                    if step >= limit:
                        return i
                    row[other] = step
                    queue[tail] = other
                    tail += 1
    return -1


@njit(cache=True, nogil=True)
def _heap_push(keys: np.ndarray, items: np.ndarray, size: int, key: np.int64, item: int) -> None:
    position = size
    while position > 0:
        parent = (position - 1) >> 1
        if keys[parent] <= key:
            break
        keys[position] = keys[parent]
        items[position] = items[parent]
        position = parent
    keys[position] = key
    items[position] = item


@njit(cache=True, nogil=True)
def _heap_pop(keys: np.ndarray, items: np.ndarray, size: int) -> int:
    """Removes the smallest key's item (``size`` is the size before) and returns it."""
    top = items[0]
    size -= 1
    key, item = keys[size], items[size]
    position = 0
    while True:
        child = 2 * position + 1
        if child >= size:
            break
        if child + 1 < size and keys[child + 1] < keys[child]:
            child += 1
        if keys[child] >= key:
            break
        keys[position] = keys[child]
        items[position] = items[child]
        position = child
    keys[position] = key
    items[position] = item
    return top


@njit(cache=True, nogil=True)
def estimate(
    cell: int, goal: int, cell_row: np.ndarray, cell_col: np.ndarray, landmarks: np.ndarray
) -> int:
    """A lower bound of the moves from ``cell`` to ``goal``: the Manhattan distance, or
    where larger the differential bound of a landmark ``L`` (a row of ``landmarks``, its
    distances from every cell), ``|d(L, goal) - d(L, cell)|`` (the triangle inequality;
    Goldberg and Harrelson's ALT), which sees round walls that Manhattan cannot."""
    h = abs(cell_row[cell] - cell_row[goal]) + abs(cell_col[cell] - cell_col[goal])
    for k in range(landmarks.shape[0]):
        a, b = np.int64(landmarks[k, cell]), np.int64(landmarks[k, goal])
        if a != UNREACHABLE and b != UNREACHABLE and abs(a - b) > h:
            h = abs(a - b)
    return h


@njit(cache=True, nogil=True)
def shortest_path(
    neighbours: np.ndarray,
    cell_row: np.ndarray,
    cell_col: np.ndarray,
    source: int,
    goal: int,
    scratch: np.ndarray,
    generation: int,
    path: np.ndarray,
    landmarks: np.ndarray,
    weight16: int = 16,
) -> int:
    """A* from ``source`` to ``goal`` (columns), weighted by ``weight16 / 16`` (16:
    exact), ties broken towards the goal (deepest first), so that on open floor it walks
    straight at it. Its heuristic is the larger of the Manhattan distance and the
    landmarks' bound (:func:`estimate`), both consistent. Writes the path,
    ``source`` first and ``goal`` last, into ``path`` and returns its number of moves, or
    -1 if ``goal`` cannot be reached. A weight ``w`` above 1 finds a path at most ``w``
    times the shortest (weighted A*'s bound) after far fewer expansions: on a floor with
    10 % random obstacles, paths 1,350 moves long, ``17 / 16`` expands about a fifth as
    many cells as the exact search for paths 2.4 % longer on average.

    ``scratch`` is an ``(n, 4)`` int32 array kept between calls: per cell the generation
    that last reached it, its cost so far, its parent and the generation that expanded
    it; ``generation`` must differ from every earlier call's (a counter), so nothing
    needs clearing between searches. An expanded cell is never opened again (Likhachev's
    ARA* shows the weight's bound holds without it, and reopening cost more than the
    weight saved).
    """
    if source == goal:
        path[0] = source
        return 0
    capacity = 1024
    keys = np.empty(capacity, dtype=np.int64)
    items = np.empty(capacity, dtype=np.int32)
    # A key orders by f = g + h, then by larger g: f << 32 | (2**32 - 1 - g).
    low = np.int64(0xFFFFFFFF)
    scratch[source, 0], scratch[source, 1], scratch[source, 2] = generation, 0, -1
    h = estimate(source, goal, cell_row, cell_col, landmarks)
    _heap_push(keys, items, 0, (np.int64(h * weight16) << 32) | low, source)
    size = 1
    while size > 0:
        key = keys[0]
        cell = _heap_pop(keys, items, size)
        size -= 1
        g = scratch[cell, 1]
        if (low - (key & low)) != g or scratch[cell, 3] == generation:
            continue  # a stale entry (reached more cheaply since), or expanded already
        scratch[cell, 3] = generation
        if cell == goal:
            length = g
            for k in range(length, -1, -1):
                path[k] = cell
                cell = scratch[cell, 2]
            return length
        for k in range(4):
            other = neighbours[cell, k]
            if other < 0:
                continue
            if scratch[other, 0] == generation and (
                scratch[other, 1] <= g + 1 or scratch[other, 3] == generation
            ):
                continue  # no cheaper, or expanded: weighted A* keeps its bound unreopened
            scratch[other, 0], scratch[other, 1], scratch[other, 2] = generation, g + 1, cell
            h = estimate(other, goal, cell_row, cell_col, landmarks)
            if size == capacity:
                capacity *= 2
                keys = np.concatenate((keys, np.empty_like(keys)))
                items = np.concatenate((items, np.empty_like(items)))
            f = np.int64(16 * (g + 1) + weight16 * h)
            _heap_push(keys, items, size, (f << 32) | (low - (g + 1)), other)
            size += 1
    return -1


#: What :func:`guided_pass` writes for a query it cannot answer from the stored path: the
#: robot's own cell is off it (a new path is needed from there), or a cell is neither on it
#: nor beside it (a search of its own is needed).
NEEDS_NEW_PATH, NEEDS_SEARCH = -1, -2


@njit(cache=True, nogil=True)
def group_centres(slots: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """For queries grouped by ``slots`` (a goal each), whether each is its group's centre:
    the cell on or beside the most queries of its group (the last in order among equals),
    that is, the robot's own cell when a planner asks for a robot's cell and its four
    neighbours (a blocked move asks for the robot's cell again; the planner lists the
    robot's cell last). A group of more than 16 queries takes its last as its centre."""
    n = slots.shape[0]
    order = np.argsort(slots, kind="mergesort")
    centre = np.zeros(n, dtype=np.bool_)
    start = 0
    while start < n:
        end = start
        while end < n and slots[order[end]] == slots[order[start]]:
            end += 1
        best, best_count = order[end - 1], -1
        if end - start <= 16:
            for a in range(start, end):
                count = 0
                for b in range(start, end):
                    i, j = order[a], order[b]
                    if abs(rows[i] - rows[j]) + abs(cols[i] - cols[j]) <= 1:
                        count += 1
                if count >= best_count:
                    best, best_count = order[a], count
        centre[best] = True
        start = end
    return centre


@njit(cache=True, nogil=True)
def guided_pass(
    columns: np.ndarray,
    rows: np.ndarray,
    cols: np.ndarray,
    slots: np.ndarray,
    centre: np.ndarray,
    pool: np.ndarray,
    path_start: np.ndarray,
    path_moves: np.ndarray,
    cursor: np.ndarray,
    cell_row: np.ndarray,
    cell_col: np.ndarray,
    window: int,
    out: np.ndarray,
) -> None:
    """Answers queries (``columns``, at ``rows``/``cols``) from their goals' stored paths
    (slot ``s``: ``pool[path_start[s] : path_start[s] + path_moves[s] + 1]``, goal last),
    looking ``window`` cells either side of the slot's cursor (where its robot was last):

    - a cell on the path: the moves left along it (the cursor moves there if the query is
      its group's ``centre``);
    - a centre off the path, or a slot with no path: :data:`NEEDS_NEW_PATH`;
    - another cell beside the path: one more than the least moves left from a path cell
      beside it (an upper bound with the parity of the true distance);
    - any other cell: :data:`NEEDS_SEARCH`.
    """
    for i in range(columns.shape[0]):
        s = slots[i]
        moves = path_moves[s]
        if moves < 0:
            out[i] = NEEDS_NEW_PATH
            continue
        start, here = path_start[s], cursor[s]
        hit, bound = -1, np.int64(-1)
        for k in range(max(0, here - window), min(moves, here + window) + 1):
            cell = pool[start + k]
            if cell == columns[i]:
                hit = k
                break
            beside = abs(cell_row[cell] - rows[i]) + abs(cell_col[cell] - cols[i]) == 1
            if beside and (bound < 0 or moves - k + 1 < bound):
                bound = moves - k + 1
        if hit >= 0:
            out[i] = moves - hit
            if centre[i]:
                cursor[s] = hit
        elif centre[i]:
            out[i] = NEEDS_NEW_PATH
        elif bound >= 0:
            out[i] = bound
        else:
            out[i] = NEEDS_SEARCH


#: The guidance's compiled functions, moved to :mod:`warehouse_phys.planners.traffic_flow`
#: (which imports this module's heap), still found here.
_MOVED = ("add_flow", "congestion_path", "follow_paths", "follow_values")


def __getattr__(name: str) -> Any:
    if name in _MOVED:
        from warehouse_phys.planners import traffic_flow  # on demand: it imports this module

        return getattr(traffic_flow, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
