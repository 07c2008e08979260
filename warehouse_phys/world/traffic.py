"""The traffic rule of a fleet: which of the robots' simultaneous moves are granted.

Every robot of a fleet chooses an action at once: one of the four moves of
:class:`~warehouse_phys.world.grid.Action` or :data:`WAIT`. The rule, applied by
:func:`resolve_moves`:

1. A move into a wall or a shelf is refused by the floor (the robot stays), as
   for a single robot. A waiting robot, and a *parked* one (done with its
   package), stays.
2. Among robots moving into the same cell, the lowest-numbered goes and the
   others wait.
3. A robot moving into a cell whose occupant does not leave waits. Two robots
   swapping cells both wait. This is applied until nothing changes, so that a
   chain of robots following each other moves together, and so does a rotation
   of three or more robots around a cycle.
4. A *corner follow*, a robot entering a cell whose occupant leaves it at a right
   angle to the follower's move, brings the two discs within ``sqrt(0.5)`` of a
   cell of each other halfway through the move (both driven by the same
   controller: the follower at ``(p, 0)``, the leader at ``(1, p)``). It is
   granted only when ``corner_follows`` is true, which
   :func:`corner_follows_are_safe` decides from the robots' size; otherwise the
   follower waits.

:func:`resolve_moves` applies the rule with array operations, O(N) per joint step
(the chains and cycles of rule 3 by pointer doubling), and grants exactly what the
first, loop-until-stable version granted (golden outcomes in the tests).

**Clearance.** In the physics twin every robot is driven by the same controller
from rest on its centre, which carries it at most ``o`` past the centre a free
move enters, at most ``b`` past its own centre when a bump into a wall drives it
back, and at most ``s`` sideways (:class:`~warehouse_phys.physics.ControllerMotion`,
measured by :func:`~warehouse_phys.physics.check_controller`). With ``e = max(o, b, s)``,
the centres of two robots in a granted step come no closer than [cells]:

- a straight follow at one cell: ``1 - 2s`` (the same motion, one cell apart);
- a corner follow: ``sqrt(0.5) - 2s`` (see rule 4);
- a robot passing beside one that waits, bumps or passes: ``1 - 2s`` or more;
- a robot entering the cell next to one that waits (converging robots where one
  goes and the others wait) or that bumps back towards it: ``1 - e``;
- two robots entering neighbouring cells head-on, or bumping back to back: ``1 - 2e``.

A turning robot (:mod:`warehouse_phys.world.headings`) that turns or waits holds its
centre as a waiting robot does (the controller check measures how far a turn moves the
centre and counts it as sideways drift ``s``), and its forward move is a free move
along its heading, so the same distances hold for turning fleets.

Robots that start farther apart, or diagonally, stay farther apart. So discs of
diameter ``d`` never touch when ``1 - 2e >= d + CLEARANCE_MARGIN`` and, where corner
follows are granted, ``sqrt(0.5) - 2s >= d + CLEARANCE_MARGIN``: :func:`check_clearance`
refuses any setting of the physics fleet that breaks either. Like
:mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from warehouse_phys.world.grid import ACTION_DELTAS, WarehouseGrid

#: The fleet's extra action: stay on the cell (yielding is how fleets avoid deadlock).
WAIT = 4
#: Number of fleet actions: the four moves and WAIT.
FLEET_ACTIONS = 5

#: Closest two robots' centres come in a corner follow [cells]: sqrt(0.5).
CORNER_FOLLOW_DISTANCE = math.sqrt(0.5)
#: Room the controller needs beyond the discs' diameter in a corner follow [cells]:
#: the two robots' profiles are identical, but a margin covers overshoot and settling.
CORNER_FOLLOW_MARGIN = 0.05


#: Room left between two discs beyond what the controller's measured motion takes
#: [cells]: a margin for histories of moves that the controller check does not try.
CLEARANCE_MARGIN = 0.02


def check_clearance(
    robot_diameter: float, overshoot: float, bump_overshoot: float, drift: float
) -> None:
    """Refuse a robot and controller that the rule's granted steps could bring into contact.

    Args:
        robot_diameter: The discs' diameter [cells].
        overshoot, bump_overshoot, drift: How far the controller carries a robot past
            a free move's cell, past its own cell after a bump, and sideways [cells]
            (:class:`~warehouse_phys.physics.ControllerMotion`).

    Raises:
        ValueError: naming the tightest situation, its closest approach, the bound
            (``d + CLEARANCE_MARGIN``) and the diameters this controller allows, if any.
    """
    reach = max(overshoot, bump_overshoot, drift)
    need = robot_diameter + CLEARANCE_MARGIN
    motion = (
        f"the controller carries a robot up to {overshoot:.3g} cells past a free move's "
        f"centre, {bump_overshoot:.3g} past its own after a bump and {drift:.3g} sideways"
    )
    advice = (
        "make the controller overshoot less (lower max_speed or max_force, raise "
        "robot_mass or floor_damping)"
    )
    if 1 - 2 * reach < need:
        situation = (
            "two robots entering neighbouring cells head-on"
            if reach == overshoot
            else "two robots bumping back to back"
            if reach == bump_overshoot
            else "two robots passing side by side"
        )
        largest = 1 - 2 * reach - CLEARANCE_MARGIN
        allowed = (
            f"the diameter may be at most {largest:.3g} cells (robot_radius over cell_size "
            f"at most half that), or {advice}"
            if largest > 0
            else f"no robot is small enough for this controller: {advice}"
        )
        raise ValueError(
            f"robots of diameter {robot_diameter:.3g} cells are too large for this "
            f"controller in a fleet: {motion}, so {situation} come within 1 - 2 x "
            f"{reach:.3g} = {1 - 2 * reach:.3g} cells, less than the diameter plus a "
            f"margin of {CLEARANCE_MARGIN} ({need:.3g}); {allowed}"
        )
    corner = CORNER_FOLLOW_DISTANCE - 2 * drift
    if corner_follows_are_safe(robot_diameter) and corner < need:
        smallest_without = CORNER_FOLLOW_DISTANCE - CORNER_FOLLOW_MARGIN
        raise ValueError(
            f"robots of diameter {robot_diameter:.3g} cells would touch following each "
            f"other round a corner: {motion}, so they come within sqrt(0.5) - 2 x "
            f"{drift:.3g} = {corner:.3g} cells, less than {need:.3g}; the diameter may be "
            f"at most {corner - CLEARANCE_MARGIN:.3g} cells, or at least "
            f"{smallest_without:.3g} (robots that large do not follow round corners), or "
            "make the controller drift less sideways"
        )


def corner_follows_are_safe(robot_diameter: float) -> bool:
    """Whether robots of ``robot_diameter`` [cells] may follow each other round a corner:
    their diameter plus :data:`CORNER_FOLLOW_MARGIN` is below :data:`CORNER_FOLLOW_DISTANCE`.
    The default robot (0.6 of a cell) is."""
    return robot_diameter + CORNER_FOLLOW_MARGIN < CORNER_FOLLOW_DISTANCE


def neighbour_table(grid: WarehouseGrid) -> np.ndarray:
    """The cell each action leads to from every cell, as a read-only ``(rows * cols, 5)``
    int64 array of cell indices (``row * cols + col``): actions 0..3 as
    :meth:`WarehouseGrid.move` (a move into a wall or a shelf stays), 4 (:data:`WAIT`)
    stays. Floors of the same size and layout share one table."""
    return _floor_tables(grid)[0]


def _floor_tables(grid: WarehouseGrid) -> tuple[np.ndarray, np.ndarray]:
    """The floor's neighbour table and a scratch array over its cells holding
    :data:`_NOBODY` between calls (so a joint step touches only its robots' cells)."""
    if grid is _LAST_FLOOR[0]:  # the usual case: the same floor as the last call
        return _LAST_FLOOR[1]
    key = (grid.rows, grid.cols, grid.layout)
    tables = _NEIGHBOUR_TABLES.pop(key, None)
    if tables is None:
        rows, cols = grid.rows, grid.cols
        free = grid.free_mask
        row, col = np.divmod(np.arange(rows * cols, dtype=np.int64), cols)
        table = np.empty((rows * cols, FLEET_ACTIONS), dtype=np.int64)
        table[:, WAIT] = row * cols + col
        for action, (d_row, d_col) in enumerate(ACTION_DELTAS):
            to_row, to_col = row + d_row, col + d_col
            inside = (to_row >= 0) & (to_row < rows) & (to_col >= 0) & (to_col < cols)
            allowed = inside.copy()
            allowed[inside] = free[to_row[inside], to_col[inside]]
            table[:, action] = np.where(allowed, to_row * cols + to_col, table[:, WAIT])
        table.flags.writeable = False
        tables = table, np.full(rows * cols, _NOBODY, dtype=np.int64)
    _NEIGHBOUR_TABLES[key] = tables  # most recently used last
    while len(_NEIGHBOUR_TABLES) > _NEIGHBOUR_TABLES_KEPT:
        del _NEIGHBOUR_TABLES[next(iter(_NEIGHBOUR_TABLES))]
    _LAST_FLOOR[:] = [grid, tables]
    return tables


def resolve_moves(
    grid: WarehouseGrid,
    cells: np.ndarray | Sequence[tuple[int, int]],
    actions: np.ndarray | Sequence[int],
    parked: np.ndarray | Sequence[bool] | None = None,
    *,
    corner_follows: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Apply the traffic rule (see the module) to one joint step, in O(N) array operations.

    Args:
        grid: The floor.
        cells: Each robot's ``(row, col)``, shape ``(N, 2)``; no two the same.
        actions: Each robot's action, 0..3 (a move) or :data:`WAIT`.
        parked: Which robots are parked (never move); default none.
        corner_follows: Whether corner follows are granted.

    Returns:
        The cell each robot ends on (``(N, 2)`` int64), and whether traffic refused
        its move (``(N,)`` bool: a move that the floor alone would have allowed,
        turned into a wait).

    Raises:
        ValueError: if two robots share a cell, a cell is off the floor or an action
            is not 0..4.
    """
    here, act, parked = _checked_joint(grid, cells, actions, parked)
    ends, refused, _ = granted_moves(grid, here, act, parked, corner_follows=corner_follows)
    rows_cols = np.empty((len(ends), 2), dtype=np.int64)
    np.divmod(ends, grid.cols, out=(rows_cols[:, 0], rows_cols[:, 1]))
    return rows_cols, refused


class Grants(NamedTuple):
    """What the rule decides for one joint step, robot by robot (``(N,)`` arrays)."""

    #: The cell index (``row * cols + col``) each robot ends on.
    ends: np.ndarray
    #: Whether traffic turned a move the floor allows into a wait.
    refused: np.ndarray
    #: Whether the floor refused the move: a move into a wall or a shelf (rule 1),
    #: which a robot in the physics twin drives, bumps and drives back.
    bumped: np.ndarray


def granted_moves(
    grid: WarehouseGrid,
    here: np.ndarray,
    actions: np.ndarray,
    parked: np.ndarray | None,
    *,
    corner_follows: bool = True,
) -> Grants:
    """:func:`resolve_moves` on cell indices (``row * cols + col``), without checking its
    arguments: for callers that keep them valid (the fleet; ``parked=None`` when no
    robot can be parked). Returns every decision of the rule (:class:`Grants`)."""
    table, _ = _floor_tables(grid)
    act = actions if parked is None else np.where(parked, WAIT, actions)
    return grant_wanted(grid, here, table[here, act], act, corner_follows=corner_follows)


def grant_wanted(
    grid: WarehouseGrid,
    here: np.ndarray,
    wanted: np.ndarray,
    directions: np.ndarray,
    *,
    corner_follows: bool = True,
) -> Grants:
    """The rule (rules 2 to 4 of the module) for robots that each want one cell: the
    traffic rule of every move model (the turning robot's too,
    :mod:`warehouse_phys.world.headings`), without checking its arguments.

    Args:
        grid: The floor.
        here: ``(N,)`` each robot's cell index.
        wanted: ``(N,)`` the cell each robot heads for: a neighbour, or its own cell
            when it stays or the floor refuses its move (rule 1, already applied).
        directions: ``(N,)`` the direction of each robot's move as a grid action
            (0..3), :data:`WAIT` for a robot that does not try to move; a robot with a
            direction that stays put bumped into a wall or shelf.
        corner_follows: Whether corner follows are granted.
    """
    n = len(here)
    _, scratch = _floor_tables(grid)
    free = wanted != here  # the moves the floor allows
    bumped = (directions != WAIT) > free  # rule 1: the floor refuses (a move, not allowed)
    moving = free.copy()
    robots = _ROBOT_NUMBERS.get(n)
    if robots is None:  # 0..n-1, read-only, kept for fleets of this size
        robots = _ROBOT_NUMBERS[n] = _read_only_range(n)

    # Rule 2: the lowest-numbered of the robots heading for one cell goes.
    movers = moving.nonzero()[0]
    heading = wanted[movers]
    np.minimum.at(scratch, heading, movers)
    moving &= scratch[wanted] == robots
    scratch[heading] = _NOBODY
    # Rules 3 and 4. Robot i heads for robot j's cell: i goes only if j goes, they do
    # not swap and, without corner follows, j leaves the same way. After rule 2 at most
    # one robot heads for each cell, so "i waits for j" links form chains and cycles:
    # i goes iff every robot down its chain (round its cycle) may go, an AND along the
    # links taken by pointer doubling.
    scratch[here] = robots
    occupant = scratch[wanted]  # the robot on the cell each robot heads for, if any
    scratch[here] = _NOBODY
    follows = (occupant != _NOBODY) & moving
    may_go = moving
    if np.count_nonzero(follows):  # (cheaper than .any() on a few robots)
        may_go = moving.copy()
        leader = np.where(follows, occupant, robots)
        ahead = leader[follows]
        may_go[follows] &= moving[ahead] & (wanted[ahead] != here[follows])
        if not corner_follows:
            may_go[follows] &= directions[ahead] == directions[follows]
        for _ in range(max(1, n).bit_length()):
            further = leader[leader]
            may_go &= may_go[leader]
            if not np.count_nonzero(further != leader):
                break
            leader = further
        else:  # a cycle: 2**bit_length(n) >= n links, round it and beyond
            may_go &= may_go[leader]
    return Grants(np.where(may_go, wanted, here), free > may_go, bumped)


def moves_refused_by_floor(
    grid: WarehouseGrid,
    cells: np.ndarray | Sequence[tuple[int, int]],
    actions: np.ndarray | Sequence[int],
    parked: np.ndarray | Sequence[bool] | None = None,
) -> np.ndarray:
    """Which robots bump: a move (not :data:`WAIT`, not parked) into a wall or a shelf,
    which the floor refuses as for a single robot (the physics twin drives it and
    drives back). ``(N,)`` bool; the arguments as for :func:`resolve_moves`."""
    here, act, parked = _checked_joint(grid, cells, actions, parked)
    return granted_moves(grid, here, act, parked).bumped


def robot_cell_indices(
    grid: WarehouseGrid, cells: np.ndarray | Sequence[tuple[int, int]], prefix: str = ""
) -> np.ndarray:
    """Robots' ``(N, 2)`` cells as cell indices ``row * cols + col``, each on the floor and
    no two alike, or a one-line ``ValueError`` (starting with ``prefix``) naming the robot."""
    cells = np.asarray(cells)
    if cells.size == 0:
        cells = cells.reshape(0, 2)
    if cells.ndim != 2 or cells.shape[1] != 2 or cells.dtype.kind not in "iu":
        raise ValueError(
            f"{prefix}cells must be N (row, col) integer pairs, got shape {cells.shape}"
        )
    rows, cols = cells[:, 0].astype(np.int64), cells[:, 1].astype(np.int64)
    off = (rows < 0) | (rows >= grid.rows) | (cols < 0) | (cols >= grid.cols)
    if off.any():
        i = int(np.flatnonzero(off)[0])
        raise ValueError(f"{prefix}robot {i}'s cell {tuple(cells[i].tolist())} is off the floor")
    here = rows * grid.cols + cols
    if len(here) > 1 and len(np.unique(here)) != len(here):
        raise ValueError(f"{prefix}two robots share a cell: {[tuple(c) for c in cells.tolist()]}")
    return here


def _checked_joint(
    grid: WarehouseGrid,
    cells: np.ndarray | Sequence[tuple[int, int]],
    actions: np.ndarray | Sequence[int],
    parked: np.ndarray | Sequence[bool] | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cell indices, actions and the parked mask as arrays, or a one-line ``ValueError``."""
    here = robot_cell_indices(grid, cells)
    n = len(here)
    act = np.asarray(actions)
    if act.shape != (n,):
        raise ValueError(f"need one action per robot ({n}), got shape {act.shape}")
    if act.dtype.kind not in "iu" or ((act < 0) | (act >= FLEET_ACTIONS)).any():
        bad = [i for i, a in enumerate(act.tolist()) if a not in range(FLEET_ACTIONS)]
        if not bad:
            raise ValueError(f"actions must be integers 0..4 (4 is WAIT), got {act.dtype}")
        raise ValueError(f"robot {bad[0]}'s action must be 0..4 (4 is WAIT), got {act[bad[0]]!r}")
    parked = np.zeros(n, dtype=bool) if parked is None else np.asarray(parked, dtype=bool)
    if parked.shape != (n,):
        raise ValueError(f"need one parked flag per robot ({n}), got shape {parked.shape}")
    return here, act.astype(np.int64, copy=False), parked


_NEIGHBOUR_TABLES: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
#: "No robot" in the scratch array: above every robot number.
_NOBODY = np.iinfo(np.int64).max
#: Floors whose neighbour tables are kept (a 500 x 140 floor's is 2.8 MB).
_NEIGHBOUR_TABLES_KEPT = 16
#: ``arange(n)`` of the fleet sizes seen (a few at most; cleared when it grows past 16).
_ROBOT_NUMBERS: dict[int, np.ndarray] = {}


def _read_only_range(n: int) -> np.ndarray:
    if len(_ROBOT_NUMBERS) >= 16:
        _ROBOT_NUMBERS.clear()
    robots = np.arange(n)
    robots.flags.writeable = False
    return robots


#: The floor of the last call and its tables (floors are immutable: its tables stay right).
_LAST_FLOOR: list = [None, None]
