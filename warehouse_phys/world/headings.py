"""The turning robot: a robot that faces one of four headings, turns in place and drives
forward (the League of Robot Runners' robot model, ``moves="rotate"``).

Each robot faces :class:`Heading` ``EAST``, ``SOUTH``, ``WEST`` or ``NORTH`` (the
competition's orientations 0..3: clockwise from east, rows growing southwards) and
takes one :class:`TurnAction` a step, in the competition's numbering:

- ``FORWARD`` (0): one cell ahead; into a wall or a shelf the floor refuses it and
  the robot stays, as a four-direction move into a shelf;
- ``CLOCKWISE`` (1) and ``COUNTERCLOCKWISE`` (2): a quarter turn in place;
- ``WAIT`` (3): nothing.

Turning robots share the fleet's traffic rule (:func:`~warehouse_phys.world.traffic.grant_wanted`):
a forward move heads for the cell ahead, a turn or a wait stays; among robots heading
for one cell the lowest-numbered goes; a robot enters a cell only as its occupant
leaves it (following is allowed, swaps are not; corner follows only where the fleet's
robots are small enough). A turn never conflicts: the robot keeps its cell. A robot's
state is ``(cell, heading)``, numbered ``cell * 4 + heading`` in :func:`state_table`.

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

from collections.abc import Sequence
from enum import IntEnum
from typing import NamedTuple

import numpy as np

from warehouse_phys.world.grid import Action, WarehouseGrid
from warehouse_phys.world.traffic import (
    WAIT,
    _checked_joint,
    grant_wanted,
    granted_moves,
    neighbour_table,
)

#: The move models of a fleet: four-direction moves (the default) and turning robots.
MOVE_MODELS = ("grid", "rotate")


class Heading(IntEnum):
    """Where a turning robot faces, numbered as the competition's orientations."""

    EAST = 0
    SOUTH = 1
    WEST = 2
    NORTH = 3


class TurnAction(IntEnum):
    """A turning robot's actions, numbered as the competition's (FW, CR, CCR, W)."""

    FORWARD = 0
    CLOCKWISE = 1
    COUNTERCLOCKWISE = 2
    WAIT = 3


#: Number of turning-robot actions.
TURN_ACTIONS = 4
#: Number of headings.
HEADINGS = 4
#: The grid action of a forward move along each heading (EAST is RIGHT, ...).
HEADING_MOVES = np.array([Action.RIGHT, Action.DOWN, Action.LEFT, Action.UP], dtype=np.int64)
HEADING_MOVES.flags.writeable = False
#: The heading a grid action's move faces: the inverse of :data:`HEADING_MOVES`.
MOVE_HEADINGS = np.argsort(HEADING_MOVES)
MOVE_HEADINGS.flags.writeable = False
#: The competition's letters: headings in its output's ``start``, actions in its paths.
HEADING_LETTERS = "ESWN"
ACTION_LETTERS = "FRCW"
#: How each action changes the heading (a forward move and a wait keep it).
_TURN = np.array([0, 1, -1, 0], dtype=np.int64)


class TurnGrants(NamedTuple):
    """What the rule decides for a joint step of turning robots (``(N,)`` arrays)."""

    #: The cell index each robot ends on.
    ends: np.ndarray
    #: The heading each robot faces after the step.
    headings: np.ndarray
    #: Whether traffic turned a forward move the floor allows into a wait.
    refused: np.ndarray
    #: Whether the floor refused a forward move (a wall or a shelf ahead).
    bumped: np.ndarray


def turned(headings: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """The heading after each action (a turn changes it by a quarter, the rest keep it)."""
    return (np.asarray(headings) + _TURN[np.asarray(actions)]) % HEADINGS


def quarter_turns(headings: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """Fewest quarter turns from each of ``headings`` to face each of ``wanted``: 0..2."""
    difference = (np.asarray(wanted) - np.asarray(headings)) % HEADINGS
    return np.minimum(difference, HEADINGS - difference)


def turn_towards(headings: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """The action that brings each robot nearer to facing ``wanted``: ``WAIT`` when it
    already does, else the quarter turn on the shorter side (clockwise for a half turn)."""
    difference = (np.asarray(wanted) - np.asarray(headings)) % HEADINGS
    return np.array([TurnAction.WAIT, TurnAction.CLOCKWISE, TurnAction.CLOCKWISE,
                     TurnAction.COUNTERCLOCKWISE], dtype=np.int64)[difference]  # fmt: skip


def facing_move(actions: np.ndarray, headings: np.ndarray) -> np.ndarray:
    """The heading that makes each grid action (0..3) a forward move; a robot whose
    action is :data:`~warehouse_phys.world.traffic.WAIT` keeps its ``headings``."""
    actions = np.asarray(actions)
    return np.where(actions == WAIT, headings, MOVE_HEADINGS[np.minimum(actions, WAIT - 1)])


def ahead_cells(grid: WarehouseGrid, here: np.ndarray, headings: np.ndarray) -> np.ndarray:
    """The cell index ahead of each robot, or its own cell where a wall or a shelf is."""
    return neighbour_table(grid)[here, HEADING_MOVES[headings]]


def state_table(grid: WarehouseGrid) -> np.ndarray:
    """Where each action leads from every state: ``(rows * cols * 4, 4)`` int64 of state
    indices ``cell * 4 + heading`` (a forward move into a wall or a shelf stays)."""
    cells = grid.rows * grid.cols
    state = np.arange(cells * HEADINGS, dtype=np.int64)
    cell, heading = np.divmod(state, HEADINGS)
    table = np.empty((len(state), TURN_ACTIONS), dtype=np.int64)
    table[:, TurnAction.FORWARD] = ahead_cells(grid, cell, heading) * HEADINGS + heading
    for action in (TurnAction.CLOCKWISE, TurnAction.COUNTERCLOCKWISE, TurnAction.WAIT):
        table[:, action] = cell * HEADINGS + turned(heading, np.full_like(heading, action))
    return table


def turning_moves(
    grid: WarehouseGrid,
    here: np.ndarray,
    headings: np.ndarray,
    actions: np.ndarray,
    parked: np.ndarray | None,
    *,
    corner_follows: bool = True,
) -> TurnGrants:
    """The traffic rule for one joint step of turning robots, on cell indices, without
    checking the arguments (the fleet keeps them valid): O(N) array operations."""
    act = actions if parked is None else np.where(parked, TurnAction.WAIT, actions)
    forward = act == TurnAction.FORWARD
    moves = HEADING_MOVES[headings]
    wanted = np.where(forward, neighbour_table(grid)[here, moves], here)
    directions = np.where(forward, moves, WAIT)
    grants = grant_wanted(grid, here, wanted, directions, corner_follows=corner_follows)
    return TurnGrants(grants.ends, turned(headings, act), grants.refused, grants.bumped)


def joint_grants(
    grid: WarehouseGrid,
    here: np.ndarray,
    actions: np.ndarray,
    headings: np.ndarray | None,
    *,
    parked: np.ndarray | None,
    on_floor: np.ndarray | None,
    corner_follows: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """A fleet's joint step under its move model's traffic rule: turning robots'
    (``headings`` given) or four-direction moves' (``headings=None``); robots not
    ``on_floor`` (``None``: every robot) take no part and are no obstacles. Returns the
    cells the robots end on, which moves traffic refused, which the floor refused
    (bumps), and the headings after the step (``None`` for robots that do not turn)."""
    if on_floor is not None:
        moved, refused, bumped = here.copy(), np.zeros_like(on_floor), np.zeros_like(on_floor)
        after = None if headings is None else headings.copy()
        ends, refused[on_floor], bumped[on_floor], facing = joint_grants(
            grid, here[on_floor], actions[on_floor],
            None if headings is None else headings[on_floor],
            parked=None if parked is None else parked[on_floor], on_floor=None,
            corner_follows=corner_follows,
        )  # fmt: skip
        moved[on_floor] = ends
        if after is not None:
            after[on_floor] = facing
        return moved, refused, bumped, after
    if headings is None:
        grants = granted_moves(grid, here, actions, parked, corner_follows=corner_follows)
        return grants.ends, grants.refused, grants.bumped, None
    turns = turning_moves(grid, here, headings, actions, parked, corner_follows=corner_follows)
    return turns.ends, turns.refused, turns.bumped, turns.headings


def resolve_turning_moves(
    grid: WarehouseGrid,
    cells: np.ndarray | Sequence[tuple[int, int]],
    headings: np.ndarray | Sequence[int],
    actions: np.ndarray | Sequence[int],
    parked: np.ndarray | Sequence[bool] | None = None,
    *,
    corner_follows: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`turning_moves` on ``(row, col)`` cells, with its arguments checked.

    Returns:
        Each robot's ``(row, col)`` after the step (``(N, 2)``), its heading, and
        whether traffic refused its forward move.

    Raises:
        ValueError: if two robots share a cell, a cell is off the floor, a heading is
            not 0..3 or an action not 0..3.
    """
    headings = np.asarray(headings)
    actions = np.asarray(actions)
    n = len(np.asarray(cells).reshape(-1, 2))
    for name, values, top in (("heading", headings, HEADINGS), ("action", actions, TURN_ACTIONS)):
        if values.shape != (n,) or values.dtype.kind not in "iu":
            raise ValueError(f"need one integer {name} per robot ({n}), got {values!r}")
        bad = np.flatnonzero((values < 0) | (values >= top))
        if bad.size:
            raise ValueError(f"robot {bad[0]}'s {name} must be 0..{top - 1}, got {values[bad[0]]}")
    here, _, parked = _checked_joint(grid, cells, np.full(n, WAIT), parked)
    grants = turning_moves(grid, here, headings.astype(np.int64), actions.astype(np.int64),
                           parked, corner_follows=corner_follows)  # fmt: skip
    ends = np.stack(np.divmod(grants.ends, grid.cols), axis=1)
    return ends, grants.headings, grants.refused
