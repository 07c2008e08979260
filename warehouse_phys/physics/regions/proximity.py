"""Which bodies are near each other, and how close they came: compiled kernels.

Both the split of the floor into regions (:mod:`~warehouse_phys.physics.regions`: bodies
that may touch during the next tick share a space) and the safety measures
(:mod:`~warehouse_phys.physics.safety`: the closest approach of two bodies and the
contacts deeper than the collision slop, at every physics step) ask the same questions
of thousands of bodies every tick: which pairs lie within a radius of each other, how
close each pair came over a tick's physics steps, and how deep each disc went into a
wall or shelf. Array operations answer them in tens of numpy calls a tick; these loops,
compiled with Numba (as :mod:`warehouse_phys.planners.graph_search`'s), answer them in
one pass each, in O(N log N) and O(steps x N) time and without the GIL.

Coordinates: points are ``(N, 2)`` in any one unit; paths are ``(steps, N, 2)`` of
``(x, y)`` [m] in the space, read by the batched world after each physics step, with each
robot's floor corner ``origin`` ``(N, 2)`` [m] and the cell side ``size`` [m]: a robot's
``(row, col)`` on its floor is ``((y, x) - origin[::-1]) / size - 0.5`` (cell centres at
whole numbers), as :class:`~warehouse_phys.physics.floor_lattice.FloorLattice` has it.
Every function is pure: it reads its arguments and returns new arrays.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def near_pairs(points: np.ndarray, floors: np.ndarray, radius: float) -> np.ndarray:
    """``(P, 2)`` int64: every pair ``i < j`` of ``points`` (``(N, 2)``) on the same floor
    (``floors``, ``(N,)`` int64) at most ``radius`` apart, in an order that depends on the
    points alone.

    The points are sorted into square bins of side at least ``radius`` (a counting sort
    over the floors' bins, at most about ``8 N`` of them, wider bins on sparse floors, but
    nine a floor at least),
    and each is compared with the points of its own bin and the eight beside it: O(N + P).
    """
    n = points.shape[0]
    found = np.empty((max(16, 8 * n), 2), dtype=np.int64)
    if n < 2:
        return found[:0]
    low_row, low_col = points[:, 0].min(), points[:, 1].min()
    side = max(radius, 1e-12)
    span_rows = (points[:, 0].max() - low_row) / side + 3
    span_cols = (points[:, 1].max() - low_col) / side + 3
    n_floors = floors.max() + 1
    many = 8 * n + 4096
    while span_rows * span_cols * n_floors > many and span_rows * span_cols > 9:  # wider bins
        side *= 2.0
        span_rows, span_cols = (span_rows - 3) / 2 + 3, (span_cols - 3) / 2 + 3
    span_row = int((points[:, 0].max() - low_row) / side) + 3  # a bin of room on each side
    span_col = int((points[:, 1].max() - low_col) / side) + 3
    keys = np.empty(n, dtype=np.int64)
    for i in range(n):
        row = int((points[i, 0] - low_row) / side) + 1
        col = int((points[i, 1] - low_col) / side) + 1
        keys[i] = (floors[i] * span_row + row) * span_col + col
    head = np.zeros(n_floors * span_row * span_col + 1, dtype=np.int64)
    for i in range(n):
        head[keys[i] + 1] += 1
    head = np.cumsum(head)
    order, filled = np.empty(n, dtype=np.int64), head[:-1].copy()
    for i in range(n):  # within a bin in ascending order
        order[filled[keys[i]]] = i
        filled[keys[i]] += 1
    count, limit = 0, radius * radius
    for i in range(n):
        for d_row in range(-1, 2):
            for d_col in range(-1, 2):
                key = keys[i] + d_row * span_col + d_col
                for at in range(head[key], head[key + 1]):
                    j = order[at]
                    d_x, d_y = points[i, 0] - points[j, 0], points[i, 1] - points[j, 1]
                    if j <= i or d_x * d_x + d_y * d_y > limit:
                        continue
                    if count == found.shape[0]:
                        grown = np.empty((2 * count, 2), dtype=np.int64)
                        grown[:count] = found
                        found = grown
                    found[count, 0], found[count, 1] = i, j
                    count += 1
    return found[:count]


@njit(cache=True, nogil=True)
def pair_closest(path: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """``(P,)``: how close the two points of each pair came over ``path`` (``(steps, N,
    2)``), in the path's unit: the smallest distance at any one step."""
    closest = np.full(pairs.shape[0], np.inf)
    for p in range(pairs.shape[0]):
        i, j = pairs[p, 0], pairs[p, 1]
        least = np.inf
        for s in range(path.shape[0]):
            d_x, d_y = path[s, i, 0] - path[s, j, 0], path[s, i, 1] - path[s, j, 1]
            least = min(least, d_x * d_x + d_y * d_y)
        closest[p] = math.sqrt(least)
    return closest


@njit(cache=True, nogil=True)
def largest_travel(path: np.ndarray) -> float:
    """How far any point of ``path`` (``(steps, N, 2)``) got from where it was at the first
    step, in the path's unit."""
    largest = 0.0
    for s in range(1, path.shape[0]):
        for i in range(path.shape[1]):
            d_x, d_y = path[s, i, 0] - path[0, i, 0], path[s, i, 1] - path[0, i, 1]
            largest = max(largest, d_x * d_x + d_y * d_y)
    return math.sqrt(largest)


@njit(cache=True, nogil=True)
def wall_depths(
    path: np.ndarray, origin: np.ndarray, size: float, blocked: np.ndarray, radius: float
) -> np.ndarray:
    """``(N,)``: how deep each disc of ``radius`` [cells] went into a wall or shelf at any
    step of ``path`` (``(steps, N, 2)`` ``(x, y)`` [m], floors' corners ``origin``) [cells];
    exact for a disc that went in; for one that did not, negative (how far it kept off the
    walls beyond the edges of its cell it reached past) or ``-inf`` (it reached past none,
    or no wall was there).

    ``blocked`` is ``(rows + 2, cols + 2)`` bools, a cell ``(row, col)`` at ``(row + 1,
    col + 1)``, True for shelves and the border of walls round the floor. A disc whose
    centre is in cell ``(R, C)`` (the nearest centre) and less than half a cell across can
    reach only the cells beside it on the sides its centre leans to: the one across each
    edge (depth ``radius - (0.5 - |offset|)``) and the one across the corner between them
    (``radius`` less the distance to that corner). A centre on a blocked cell counts
    ``radius + 0.5``.
    """
    rows, cols = blocked.shape[0] - 2, blocked.shape[1] - 2
    deepest = np.full(path.shape[1], -np.inf)
    for s in range(path.shape[0]):
        for i in range(path.shape[1]):
            row = (path[s, i, 1] - origin[i, 1]) / size - 0.5
            col = (path[s, i, 0] - origin[i, 0]) / size - 0.5
            cell_row, cell_col = math.floor(row + 0.5), math.floor(col + 0.5)
            cell_row, cell_col = min(max(cell_row, -1), rows), min(max(cell_col, -1), cols)
            off_row, off_col = row - cell_row, col - cell_col
            edge_row, edge_col = 0.5 - abs(off_row), 0.5 - abs(off_col)
            a, b = cell_row + 1, cell_col + 1
            if min(edge_row, edge_col) >= radius and not blocked[a, b]:
                continue  # the disc reaches no edge of its cell: no wall is near
            step_row, step_col = (1 if off_row > 0 else -1), (1 if off_col > 0 else -1)
            depth = -np.inf
            if blocked[a, b]:
                depth = radius + 0.5
            if 0 <= a + step_row < rows + 2 and blocked[a + step_row, b]:
                depth = max(depth, radius - edge_row)
            if 0 <= b + step_col < cols + 2 and blocked[a, b + step_col]:
                depth = max(depth, radius - edge_col)
            inside = 0 <= a + step_row < rows + 2 and 0 <= b + step_col < cols + 2
            if inside and blocked[a + step_row, b + step_col]:
                corner = math.sqrt(max(edge_row, 0.0) ** 2 + max(edge_col, 0.0) ** 2)
                depth = max(depth, radius - corner)
            deepest[i] = max(deepest[i], depth)
    return deepest


@njit(cache=True, nogil=True)
def segment_gaps(start: np.ndarray, end: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """``(P,)``: the distance between the segments ``start[i] -> end[i]`` and ``start[j]
    -> end[j]`` of each pair ``(i, j)`` (``start``, ``end``: ``(N, 2)``), from the closest
    points of two segments (Ericson, *Real-Time Collision Detection*, 5.1.9)."""
    gaps = np.empty(pairs.shape[0])
    for p in range(pairs.shape[0]):
        i, j = pairs[p, 0], pairs[p, 1]
        d1x, d1y = end[i, 0] - start[i, 0], end[i, 1] - start[i, 1]
        d2x, d2y = end[j, 0] - start[j, 0], end[j, 1] - start[j, 1]
        rx, ry = start[i, 0] - start[j, 0], start[i, 1] - start[j, 1]
        a, e, f = d1x * d1x + d1y * d1y, d2x * d2x + d2y * d2y, d2x * rx + d2y * ry
        s, t = _closest_parameters(a, e, f, d1x * rx + d1y * ry, d1x * d2x + d1y * d2y)
        gap_x = rx + d1x * s - d2x * t
        gap_y = ry + d1y * s - d2y * t
        gaps[p] = math.sqrt(gap_x * gap_x + gap_y * gap_y)
    return gaps


@njit(cache=True, nogil=True)
def _clamp(value: float) -> float:
    return min(max(value, 0.0), 1.0)


@njit(cache=True, nogil=True)
def _closest_parameters(a: float, e: float, f: float, c: float, b: float) -> tuple:
    """The parameters ``(s, t)`` in [0, 1] of the closest points of two segments, from
    their squared lengths ``a``, ``e`` and the products ``f = d2.r``, ``c = d1.r``,
    ``b = d1.d2``."""
    tiny = 1e-18
    if a <= tiny and e <= tiny:
        return 0.0, 0.0
    if a <= tiny:
        return 0.0, _clamp(f / e)
    if e <= tiny:
        return _clamp(-c / a), 0.0
    denominator = a * e - b * b
    s = _clamp((b * f - c * e) / denominator) if denominator > 0 else 0.0
    t = (b * s + f) / e
    if t < 0.0:
        return _clamp(-c / a), 0.0
    if t > 1.0:
        return _clamp((b - c) / a), 1.0
    return s, t
