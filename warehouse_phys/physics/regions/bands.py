"""Which region holds each robot's bodies: bands of columns, and the robots that must
share one because their bodies may touch.

The floor is cut into ``K`` bands of whole columns (:func:`band_edges`), each with about
as many free cells as the others. Before each tick or lock-step move, every robot is
given the band of the cell it starts on (its *home*); then robots whose paths may bring
their bodies together are *linked*, and every group of linked robots that spans two
bands goes whole to the home of its lowest-numbered robot (:func:`region_of_robots`).
Robots in different regions are thus never within ``reach`` of each other along their
paths, so no contact between them goes unsimulated; the safety measures check this at
every physics step (:class:`~warehouse_phys.physics.safety.SafetyRecord`'s
``split_contacts``).

A robot's *path* for the step is the segment from where it starts to where it is driven
(its nominal position at the tick's start and end, or its cell and its aim in lock step),
in cells; two robots are linked when their segments come closer than ``reach``. A body
keeps within its controller's error ``e`` of its path, and two discs of diameter ``d``
touch only within ``d``, so ``reach = d + 2 e`` (and a margin) links every pair that can
touch. Every accepted controller keeps ``e`` below half a cell less the radius (the tick
controller check refuses more; the fleet's clearance check asks ``1 - 2 e >= d + 0.02``),
so :data:`SAFE_REACH` (``1 + 2 x`` :data:`LINK_MARGIN`) links them for every setting.
Pure functions of arrays, O(N) with the compiled neighbour search.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.world.grid import WarehouseGrid

#: Room beyond a controller's worst accepted error when linking robots [cells].
LINK_MARGIN = 0.02
#: Paths closer than this may bring two bodies of any accepted setting into contact
#: [cells]: ``d + 2 (1/2 - d/2) + 2 LINK_MARGIN``.
SAFE_REACH = 1.0 + 2 * LINK_MARGIN


def band_edges(grid: WarehouseGrid, n_regions: int) -> np.ndarray:
    """``(n_regions - 1,)`` int64: the first column of every band but the first, so that
    each band of whole columns holds about as many of the floor's free cells as the
    others (a band may be empty on a floor with fewer columns than bands)."""
    free = np.cumsum(grid.reachable_mask.sum(axis=0))
    share = free[-1] * np.arange(1, n_regions) / n_regions
    return np.searchsorted(free, share, side="left").astype(np.int64) + 1


def home_bands(cols: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """``(N,)`` int64: the band of each position's column (``cols`` [cells], centres at
    whole numbers)."""
    return np.searchsorted(edges, np.floor(np.asarray(cols) + 0.5), side="right")


def region_of_robots(
    start: np.ndarray,
    end: np.ndarray,
    floors: np.ndarray,
    edges: np.ndarray,
    reach: float = SAFE_REACH,
) -> np.ndarray:
    """``(N,)`` int64: the region of each robot for a step whose paths run from ``start``
    to ``end`` (``(N, 2)`` ``(row, col)`` [cells] on each robot's floor, ``floors``
    ``(N,)``): its home band, or for every robot of a linked group spanning two bands the
    home of the group's lowest-numbered robot (see the module)."""
    home = home_bands(start[:, 1], edges)
    if not len(edges) or len(start) < 2:
        return home
    # Imported here, at a fleet of bodies' first step: numba and SciPy's sparse graphs
    # take 0.3 s to import, which every command importing the fleets would pay.
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    from warehouse_phys.physics.regions.proximity import near_pairs, segment_gaps

    half = np.sqrt(((end - start) ** 2).sum(axis=1)).max(initial=0.0)
    middles = np.ascontiguousarray((start + end) / 2)
    pairs = near_pairs(middles, np.ascontiguousarray(floors), reach + half * 2 + 1e-9)
    pairs = pairs[segment_gaps(np.ascontiguousarray(start), np.ascontiguousarray(end),
                               pairs) < reach]  # fmt: skip
    if not (home[pairs[:, 0]] != home[pairs[:, 1]]).any():
        return home
    linked, index = np.unique(pairs, return_inverse=True)  # the robots of any link
    index = index.reshape(-1, 2)
    size = len(linked)
    graph = csr_matrix((np.ones(len(index)), (index[:, 0], index[:, 1])), shape=(size, size))
    _, group = connected_components(graph, directed=False)
    lowest = np.full(group.max() + 1, len(start), dtype=np.int64)
    np.minimum.at(lowest, group, linked)  # each group's lowest-numbered robot
    split = np.zeros(len(lowest), dtype=bool)
    crossing = home[linked[index[:, 0]]] != home[linked[index[:, 1]]]
    split[group[index[crossing, 0]]] = True
    regions = home.copy()
    moved = split[group]
    regions[linked[moved]] = home[lowest[group[moved]]]
    return regions
