"""The traffic rule of a fleet: which of the robots' simultaneous moves are granted.

Every robot of a fleet chooses an action at once: one of the four moves of
:class:`~warehouse_phys.grid.Action` or :data:`WAIT`. The rule, applied by
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

Every other pair of robots stays at least a cell apart throughout a step in
which the rule's grants are driven: a robot that follows another straight keeps
its distance of one cell, and robots in different cells that do not follow each
other never head for the same cell. Like :mod:`warehouse_phys.grid`, this module
imports neither gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from warehouse_phys.grid import Cell, WarehouseGrid

#: The fleet's extra action: stay on the cell (yielding is how fleets avoid deadlock).
WAIT = 4
#: Number of fleet actions: the four moves and WAIT.
FLEET_ACTIONS = 5
#: Most robots in one fleet.
MAX_ROBOTS = 64

#: Closest two robots' centres come in a corner follow [cells]: sqrt(0.5).
CORNER_FOLLOW_DISTANCE = math.sqrt(0.5)
#: Room the controller needs beyond the discs' diameter in a corner follow [cells]:
#: the two robots' profiles are identical, but a margin covers overshoot and settling.
CORNER_FOLLOW_MARGIN = 0.05


def corner_follows_are_safe(robot_diameter: float) -> bool:
    """Whether robots of ``robot_diameter`` [cells] may follow each other round a corner:
    their diameter plus :data:`CORNER_FOLLOW_MARGIN` is below :data:`CORNER_FOLLOW_DISTANCE`.
    The default robot (0.6 of a cell) is."""
    return robot_diameter + CORNER_FOLLOW_MARGIN < CORNER_FOLLOW_DISTANCE


def resolve_moves(
    grid: WarehouseGrid,
    cells: Sequence[tuple[int, int]],
    actions: Sequence[int],
    parked: Sequence[bool] | None = None,
    *,
    corner_follows: bool = True,
) -> tuple[list[Cell], list[bool]]:
    """Apply the traffic rule (see the module) to one joint step.

    Args:
        grid: The floor.
        cells: Each robot's cell; no two the same.
        actions: Each robot's action, 0..3 (a move) or :data:`WAIT`.
        parked: Which robots are parked (never move); default none.
        corner_follows: Whether corner follows are granted.

    Returns:
        The cell each robot ends on, and whether traffic refused its move (a
        move that the floor alone would have allowed, turned into a wait).

    Raises:
        ValueError: if two robots share a cell or an action is not 0..4.
    """
    n = len(cells)
    here = [Cell(int(r), int(c)) for r, c in cells]
    if len(set(here)) != n:
        raise ValueError(f"two robots share a cell: {[tuple(c) for c in here]}")
    parked = [False] * n if parked is None else [bool(p) for p in parked]
    wanted: list[Cell] = []
    for i, action in enumerate(actions):
        if action not in range(FLEET_ACTIONS):
            raise ValueError(f"robot {i}'s action must be 0..4 (4 is WAIT), got {action!r}")
        stays = action == WAIT or parked[i]
        wanted.append(here[i] if stays else grid.move(here[i], action))
    moving = [wanted[i] != here[i] for i in range(n)]

    # Rule 2: the lowest-numbered of the robots heading for one cell goes.
    claimed: dict[Cell, int] = {}
    for i in range(n):
        if moving[i]:
            if wanted[i] in claimed:
                moving[i] = False
            else:
                claimed[wanted[i]] = i
    # Rules 3 and 4, until nothing changes: waits only ever spread.
    occupant = {cell: i for i, cell in enumerate(here)}
    changed = True
    while changed:
        changed = False
        for i in range(n):
            if not moving[i]:
                continue
            j = occupant.get(wanted[i])
            if j is None:
                continue
            leaves = moving[j]
            swap = leaves and wanted[j] == here[i]
            corner = leaves and _direction(here[j], wanted[j]) != _direction(here[i], wanted[i])
            if not leaves or swap or (corner and not corner_follows):
                moving[i] = False
                changed = True
    ends = [wanted[i] if moving[i] else here[i] for i in range(n)]
    refused = [wanted[i] != here[i] and not moving[i] for i in range(n)]
    return ends, refused


def _direction(start: Cell, end: Cell) -> tuple[int, int]:
    return (end[0] - start[0], end[1] - start[1])
