"""One-way lanes: the way each one-cell-wide corridor of a floor is driven.

Two robots that meet head-on in a corridor one cell wide cannot pass: one must back out,
and a turning robot must first turn round (two steps, while the robots behind it wait).
Warehouses sign such aisles one way, alternating between neighbouring aisles, so that
traffic each way has a lane near it. :func:`one_way_lanes` gives every corridor cell of a
floor such a way; :class:`~warehouse_phys.planners.traffic_guidance.TrafficGuidance` lays
``GuidanceConfig.turn_lane_paths`` phantom guide paths along each lane for turning
robots, so that a guide path against a lane pays the contraflow of that many paths.

A lane is a preference, not a rule: a robot may still drive against one when the way
round costs more, and the traffic rules (:mod:`warehouse_phys.world.traffic`) are those
of any floor. Lanes can also be learned from the fleet's own traffic instead of the
floor's shape (:mod:`warehouse_phys.planners.lanes.learned`).

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.world.grid import Action

#: No lane: a cell that is not in a corridor one cell wide.
NO_LANE = -1


def _neighbours(free: np.ndarray) -> tuple[np.ndarray, ...]:
    """``free`` checked, and whether each cell's left, right, upper and lower neighbour
    is free (the floor's edge is not), each ``(rows, cols)``."""
    free = np.asarray(free)
    if free.ndim != 2 or free.dtype != bool:
        raise ValueError(f"free must be a (rows, cols) boolean mask, got {free.dtype} "
                         f"of shape {free.shape}")  # fmt: skip
    walled = np.pad(free, 1, constant_values=False)
    return free, walled[1:-1, :-2], walled[1:-1, 2:], walled[:-2, 1:-1], walled[2:, 1:-1]


def one_way_lanes(free: np.ndarray) -> np.ndarray:
    """The lane of every free cell of a floor, ``free`` its ``(rows, cols)`` boolean mask:
    ``(n,)`` int8 in row-major order of the free cells (as
    :func:`~warehouse_phys.planners.graph_search.move_graph` numbers them), the move
    (:class:`~warehouse_phys.world.grid.Action`) the lane runs by, or :data:`NO_LANE`.

    A cell is in an east-west corridor when the cells left and right of it are free and
    those above and below are not (shelves or the floor's edge); in a north-south one
    likewise. Corridors alternate: counting only the rows that hold east-west corridor
    cells, top to bottom, those of the even rows run west and those of the odd rows east;
    counting the columns that hold north-south corridor cells, left to right, those of the
    even columns run south and those of the odd ones north (so that on a grid of aisles
    the lanes round every other block of shelves form a loop). Crossings and open floor
    have no lane.

    Raises:
        ValueError: if ``free`` is not a two-dimensional boolean array.
    """
    free, left, right, up, down = _neighbours(free)
    east_west = free & left & right & ~up & ~down
    north_south = free & up & down & ~left & ~right
    lane = np.full(free.shape, NO_LANE, dtype=np.int8)
    rows = np.cumsum(east_west.any(axis=1)) - 1  # each row's rank among corridor rows
    cols = np.cumsum(north_south.any(axis=0)) - 1
    row, col = np.nonzero(east_west)
    lane[row, col] = np.where(rows[row] % 2 == 0, Action.LEFT, Action.RIGHT)
    row, col = np.nonzero(north_south)
    lane[row, col] = np.where(cols[col] % 2 == 0, Action.DOWN, Action.UP)
    return lane[free]


def floor_lanes(free: np.ndarray) -> np.ndarray:
    """Lanes over the whole floor, open floor included (after the one-way street grids of
    Jiang et al.'s guidance graphs for warehouses): ``(n, 2)`` int8 for the free cells in
    row-major order, each cell's east-west lane (:attr:`Action.LEFT` or
    :attr:`Action.RIGHT`) and its north-south lane (:attr:`Action.DOWN` or
    :attr:`Action.UP`), :data:`NO_LANE` where the cell has no free neighbour that way.

    Every cell of a row runs the same way, and so does every cell of a column: a row that
    holds east-west corridor cells one cell wide runs as :func:`one_way_lanes` runs them
    (so its corridor cells' lanes are theirs, and neighbouring corridors run opposite
    ways); any other row by its parity, even rows west and odd rows east. Columns likewise:
    by their rank among corridor columns, else even columns south and odd ones north. On
    open floor neighbouring rows (and columns) run opposite ways, so that traffic each way
    has a lane beside it.

    Raises:
        ValueError: if ``free`` is not a two-dimensional boolean array.
    """
    free, left, right, up, down = _neighbours(free)
    east_west = (free & left & right & ~up & ~down).any(axis=1)
    north_south = (free & up & down & ~left & ~right).any(axis=0)
    row_rank = np.where(east_west, np.cumsum(east_west) - 1, np.arange(free.shape[0]))
    col_rank = np.where(north_south, np.cumsum(north_south) - 1, np.arange(free.shape[1]))
    row_way = np.where(row_rank % 2 == 0, Action.LEFT, Action.RIGHT).astype(np.int8)
    col_way = np.where(col_rank % 2 == 0, Action.DOWN, Action.UP).astype(np.int8)
    lanes = np.full((*free.shape, 2), NO_LANE, dtype=np.int8)
    lanes[..., 0] = np.where(left | right, row_way[:, None], NO_LANE)
    lanes[..., 1] = np.where(up | down, col_way[None, :], NO_LANE)
    return lanes[free]
