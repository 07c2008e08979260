"""The guidance's guide paths, compiled: the traffic flow, its bookkeeping, and the
searches and reads along it.

The guidance of :mod:`warehouse_phys.planners.guidance` prices each robot's guide path by
the traffic of the fleet's other guide paths (Chen, Harabor, Li and Stuckey, "Traffic Flow
Optimisation for Lifelong Multi-Agent Path Finding", AAAI 2024) and reads the planner's
candidate values along them. Its loops, compiled with Numba like the plain searches of
:mod:`warehouse_phys.planners.graph_search` (whose move graph and heap they share), are
here: the flow added and taken off (:func:`add_flow`), the A* on moves priced by it
(:func:`congestion_path`), the robots moved along their paths (:func:`follow_paths`) and
the values of cells along them (:func:`follow_values`).

``flow`` is ``(n, 4)`` int32: how many guide paths leave each cell by each move (the move
graph's order: left, down, right, up; the move opposite ``k`` is ``(k + 2) % 4``).
Functions here are pure: they read the graph and write only the arrays they are given.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from warehouse_phys.planners.graph_search import _heap_pop, _heap_push


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
    lanes: np.ndarray,
    source: int,
    goal: int,
    costs: np.ndarray,
    scratch: np.ndarray,
    g_cost: np.ndarray,
    generation: int,
    path: np.ndarray,
    facing: int = -1,
) -> tuple[int, int]:
    """A* from ``source`` to ``goal`` (columns) on moves priced by traffic (Chen, Harabor,
    Li and Stuckey's guide paths, their sum objective): a move from ``u`` to ``v`` by move
    ``k`` costs ``1 + costs[0] * (guide paths leaving v) + costs[1] * (flow[u, k] + 1) *
    (flow[v, opposite k] + lanes[v, opposite k])`` (the vertex flow, and the contraflow
    it would meet: the paths' and the phantom paths of ``lanes``, ``(n, 4)`` int32, which
    the vertex flow does not count). Its
    heuristic is ``costs[2]`` times the Manhattan distance (1: consistent, the path is
    the cheapest; above 1, weighted A*, fewer expansions for dearer paths). Writes the
    path, ``source`` first and ``goal`` last, into ``path`` and returns its moves (-1 if
    ``goal`` cannot be reached) and the cells the search expanded (its work, which does
    not depend on the machine). ``scratch`` (``(n, 4)`` int32) and ``generation`` work as
    in :func:`~warehouse_phys.planners.graph_search.shortest_path`; ``g_cost`` (``(n,)``
    float64) holds the costs so far.

    A turning robot (``facing``: the move it faces, else -1) also pays ``costs[3]`` for
    each quarter turn, counted along the search tree (a move other than the one into the
    cell turns once; back the way it came, twice): not the exact ``(cell, heading)``
    search, which measured 3.5 times the time for 0.4 % more errands, but of equally
    priced paths it mostly finds one with fewer turns. A turn holds up the robots behind
    it for a step, so with ``costs[4]`` (optional) a quarter turn at a cell costs
    ``costs[3] * (1 + costs[4] * guide paths leaving the cell)``."""
    if source == goal:
        path[0] = source
        return 0, 0
    capacity = 1024
    keys = np.empty(capacity, dtype=np.int64)
    items = np.empty(capacity, dtype=np.int32)
    low = np.int64(0xFFFFF)  # ties: deeper first, in the key's low 20 bits
    scratch[source, 0], scratch[source, 1], scratch[source, 2] = generation, 0, -1
    g_cost[source] = 0.0
    goal_row, goal_col = cell_row[goal], cell_col[goal]
    _heap_push(keys, items, 0, low, source)
    size, expanded = 1, 0
    while size > 0:
        cell = _heap_pop(keys, items, size)
        size -= 1
        if scratch[cell, 3] == generation:
            continue  # expanded already (a stale entry)
        scratch[cell, 3] = generation
        expanded += 1
        if cell == goal:
            length = scratch[cell, 1]
            for j in range(length, -1, -1):
                path[j] = cell
                cell = scratch[cell, 2]
            return length, expanded
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
            contra = (flow[cell, k] + 1) * (flow[other, (k + 2) % 4] + lanes[other, (k + 2) % 4])
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
    return -1, expanded


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
    the start of a new path, and taken then; a path that starts the pool has no cell
    before it: ``pool[-1]`` is the pool's last cell, never written)."""
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
                k > at or (rejoin and (k > 0 or (start > 0 and pool[start - 1] < 0)))
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
