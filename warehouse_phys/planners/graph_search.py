"""Searches over a floor's moves, compiled: breadth-first distance maps, A* paths, guide paths.

The distance maps of :mod:`warehouse_phys.planners.distances` need, for thousands of goals, a
breadth-first search over a floor of up to four million cells, and for floors too big to
keep a map per goal, a shortest path per robot. Both are loops over cells whose next step
depends on the last, which array operations can only run one level at a time (one Python
round per level: thousands on a maze). They are compiled here with Numba instead, at C
speed, and cached on disk after the first run. The guidance of
:mod:`warehouse_phys.planners.guidance` needs the same for its guide paths, priced by traffic,
and for following them; they are here too, so that this stays the one module that needs a
compiler (hence its length).

The floor is a *move graph*: its free cells numbered ``0..n-1`` (their *columns*, in
reading order), and ``neighbours``, an ``(n, 4)`` int32 array of the column each move
leads to, ``-1`` where the move is blocked. Functions here are pure: they read the graph
and write only the arrays they are given.
"""

from __future__ import annotations

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


# Guidance (:mod:`warehouse_phys.planners.guidance`): guide paths priced by the traffic of
# the fleet's other guide paths, and the planner's candidate values read along them.
# ``flow`` is ``(n, 4)`` int32: how many guide paths leave each cell by each move (the
# move graph's order: left, down, right, up; the move opposite ``k`` is ``(k + 2) % 4``).


@njit(cache=True, nogil=True)
def _move_of(neighbours: np.ndarray, cell: int, other: int) -> int:
    """The move (0..3) from ``cell`` to its neighbour ``other``, -1 if none leads there."""
    for k in range(4):
        if neighbours[cell, k] == other:
            return k
    return -1


@njit(cache=True, nogil=True)
def add_flow(neighbours: np.ndarray, flow: np.ndarray, path: np.ndarray, sign: int) -> None:
    """Add (``sign`` 1) or take away (-1) the moves of ``path`` (columns, in order) to or
    from ``flow``."""
    for j in range(path.shape[0] - 1):
        k = _move_of(neighbours, path[j], path[j + 1])
        if k >= 0:
            flow[path[j], k] += sign


@njit(cache=True, nogil=True)
def congestion_path(
    neighbours: np.ndarray,
    cell_row: np.ndarray,
    cell_col: np.ndarray,
    flow: np.ndarray,
    source: int,
    goal: int,
    costs: np.ndarray,
    scratch: np.ndarray,
    g_cost: np.ndarray,
    generation: int,
    path: np.ndarray,
    facing: int = -1,
) -> int:
    """A* from ``source`` to ``goal`` (columns) on moves priced by traffic (Chen, Harabor,
    Li and Stuckey's guide paths, their sum objective): a move from ``u`` to ``v`` by move
    ``k`` costs ``1 + costs[0] * (guide paths leaving v) + costs[1] * (flow[u, k] + 1) *
    flow[v, opposite k]`` (the vertex flow, and the contraflow it would meet). Its
    heuristic is ``costs[2]`` times the Manhattan distance (1: consistent, the path is
    the cheapest; above 1, weighted A*, fewer expansions for dearer paths). Writes the
    path, ``source`` first and ``goal`` last, into ``path`` and returns its moves, or -1
    if ``goal`` cannot be reached. ``scratch`` (``(n, 4)`` int32) and ``generation`` work
    as in :func:`shortest_path`; ``g_cost`` (``(n,)`` float64) holds the costs so far.

    A turning robot (``facing``: the move it faces, else -1) also pays ``costs[3]`` for
    each quarter turn, counted along the search tree (a move other than the one into the
    cell turns once; back the way it came, twice): not the exact ``(cell, heading)``
    search, which measured 3.5 times the time for 0.4 % more errands, but of equally
    priced paths it mostly finds one with fewer turns. A turn holds up the robots behind
    it for a step, so with ``costs[4]`` (optional) a quarter turn at a cell costs
    ``costs[3] * (1 + costs[4] * guide paths leaving the cell)``."""
    if source == goal:
        path[0] = source
        return 0
    capacity = 1024
    keys = np.empty(capacity, dtype=np.int64)
    items = np.empty(capacity, dtype=np.int32)
    low = np.int64(0xFFFFF)  # ties: deeper first, in the key's low 20 bits
    scratch[source, 0], scratch[source, 1], scratch[source, 2] = generation, 0, -1
    g_cost[source] = 0.0
    goal_row, goal_col = cell_row[goal], cell_col[goal]
    _heap_push(keys, items, 0, low, source)
    size = 1
    while size > 0:
        cell = _heap_pop(keys, items, size)
        size -= 1
        if scratch[cell, 3] == generation:
            continue  # expanded already (a stale entry)
        scratch[cell, 3] = generation
        if cell == goal:
            length = scratch[cell, 1]
            for j in range(length, -1, -1):
                path[j] = cell
                cell = scratch[cell, 2]
            return length
        g, depth = g_cost[cell], scratch[cell, 1] + 1
        came = facing  # the move it made into this cell (turning robots only)
        turn = 0.0  # the price of a quarter turn here
        if facing >= 0:
            if cell != source:
                came = _move_of(neighbours, scratch[cell, 2], cell)
            turn = costs[3]
            if costs.shape[0] > 4:
                here = flow[cell, 0] + flow[cell, 1] + flow[cell, 2] + flow[cell, 3]
                turn *= 1.0 + costs[4] * here
        for k in range(4):
            other = neighbours[cell, k]
            if other < 0 or scratch[other, 3] == generation:
                continue
            vertex = flow[other, 0] + flow[other, 1] + flow[other, 2] + flow[other, 3]
            contra = (flow[cell, k] + 1) * flow[other, (k + 2) % 4]
            cost = g + 1.0 + costs[0] * vertex + costs[1] * contra
            if facing >= 0 and k != came:
                cost += turn * (2.0 if k == (came + 2) % 4 else 1.0)
            if scratch[other, 0] == generation and g_cost[other] <= cost:
                continue
            scratch[other, 0], scratch[other, 1], scratch[other, 2] = generation, depth, cell
            g_cost[other] = cost
            h = abs(cell_row[other] - goal_row) + abs(cell_col[other] - goal_col)
            if size == capacity:
                capacity *= 2
                keys = np.concatenate((keys, np.empty_like(keys)))
                items = np.concatenate((items, np.empty_like(items)))
            f = np.int64((cost + costs[2] * h) * 256.0)
            _heap_push(keys, items, size, (f << 20) | (low - min(depth, low)), other)
            size += 1
    return -1


@njit(cache=True, nogil=True)
def follow_paths(
    neighbours: np.ndarray,
    flow: np.ndarray,
    pool: np.ndarray,
    path_start: np.ndarray,
    path_moves: np.ndarray,
    cursor: np.ndarray,
    here: np.ndarray,
    window: int,
    rejoin: bool,
    status: np.ndarray,
) -> None:
    """Move each robot's cursor along its guide path (robot ``i``'s path is
    ``pool[path_start[i] : path_start[i] + path_moves[i] + 1]``, ``path_moves[i] < 0``:
    none) to where it stands (column ``here[i]``), taking the moves it made off
    ``flow``, and write ``status[i]``: 0 on its path; 1 no path, or off the next
    ``window`` cells of its path (a new search is needed).

    A robot one move beside a cell of its path ahead of the one it stood on rejoins it
    (with ``rejoin``, also one beside that cell: pushed aside or back): its path becomes its own
    cell, then the path from the farthest of those cells beside it, written in place over
    the cell before that one (``pool[path_start[i] - 1]`` is kept free for a robot beside
    the start of a new path, and taken then)."""
    for i in range(here.shape[0]):
        moves = path_moves[i]
        status[i] = 1
        if moves < 0:
            continue
        start, at = path_start[i], cursor[i]
        last = min(moves, at + window)
        found, beside = -1, -1
        for k in range(at, last + 1):
            cell = pool[start + k]
            if cell == here[i]:
                found = k
            elif _move_of(neighbours, here[i], cell) >= 0 and (
                k > at or (rejoin and (k > 0 or pool[start - 1] < 0))
            ):
                beside = k
        if found < 0 and beside < 0:
            continue
        target = found if found >= 0 else beside - 1
        for k in range(at, target + 1 if found < 0 else target):
            step = _move_of(neighbours, pool[start + k], pool[start + k + 1])
            if step >= 0:
                flow[pool[start + k], step] -= 1
        if found < 0:  # rejoin: here, then the path from ``beside`` on
            pool[start + target] = here[i]
            flow[here[i], _move_of(neighbours, here[i], pool[start + beside])] += 1
        if target < 0:  # the free cell before the path's start: now its start
            path_start[i], path_moves[i], target = start - 1, moves + 1, 0
        cursor[i] = target
        status[i] = 0


@njit(cache=True, nogil=True)
def follow_values(
    pool: np.ndarray,
    path_start: np.ndarray,
    path_moves: np.ndarray,
    cursor: np.ndarray,
    cell_row: np.ndarray,
    cell_col: np.ndarray,
    candidates: np.ndarray,
    robots: np.ndarray,
    window: int,
    values: np.ndarray,
    beside_cost: float = 1.0,
) -> None:
    """The values of ``robots``' candidate cells (``candidates``, ``(m, c)`` columns, -1
    for none) along their guide paths, written into ``values`` (``(m, c)``): a cell on
    the next ``window`` cells of the path, the moves left along it from there; a cell
    beside them, ``beside_cost`` more than the least such (1: the guide path's distance,
    as Chen et al.'s guided PIBT ranks moves); any other cell, ``inf``. A robot that
    stands on its path (:func:`follow_paths`) values its next path cell one below staying."""
    for r in range(robots.shape[0]):
        i = robots[r]
        start, at, moves = path_start[i], cursor[i], path_moves[i]
        last = min(moves, at + window)
        for c in range(candidates.shape[1]):
            cell = candidates[r, c]
            best = np.inf
            if cell >= 0:
                row, col = cell_row[cell], cell_col[cell]
                for k in range(at, last + 1):
                    other = pool[start + k]
                    apart = abs(cell_row[other] - row) + abs(cell_col[other] - col)
                    if apart <= 1 and apart * beside_cost + moves - k < best:
                        best = apart * beside_cost + moves - k
            values[r, c] = best
