"""A tick's arguments checked against the batched world: one-line errors naming them.

:meth:`~warehouse_phys.physics.batched.BatchedPhysicsWorld.drive_tick` takes each robot's
cell ``left``, the cell it ``entered``, the fractions of its move done ``before`` and
``after`` the tick, the moves that ``ended``, the tick's ``tick_steps`` and, for turning
robots, the headings before and after each action (:mod:`~warehouse_phys.physics.ticking`
gives their geometry). :func:`check_tick` checks them all against the world, as they are
and against where the last tick left each robot, and returns them as a :class:`Tick`;
every refusal is one line that starts with the argument's name and names the first robot
at fault.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from warehouse_phys.execution.ticks import check_whole
from warehouse_phys.physics.config import MAX_STEPS_PER_MOVE
from warehouse_phys.physics.ticking import HEADING_STEPS, signed_turns

if TYPE_CHECKING:
    from warehouse_phys.physics.batched import BatchedPhysicsWorld

#: A tick's ``before`` may differ from the fraction the last tick left by this much.
FRACTION_TOLERANCE = 1e-9


class Tick(NamedTuple):
    """One tick's checked arguments (see :meth:`BatchedPhysicsWorld.drive_tick`)."""

    entered: np.ndarray  # (N, 2) int64 (row, col)
    before: np.ndarray  # (N,) float64
    after: np.ndarray  # (N,) float64
    ended: np.ndarray  # (N,) bool
    tick_steps: int
    #: Turning robots: ``(N,)`` int64 the heading each action ends facing, and its
    #: signed quarter turns (1 clockwise, -1 counter-clockwise, 0); ``None`` otherwise.
    headings_after: np.ndarray | None = None
    turns: np.ndarray | None = None


def check_tick(
    world: BatchedPhysicsWorld,
    left: object,
    entered: object,
    before: object,
    after: object,
    ended: object,
    tick_steps: object,
    headings_before: object = None,
    headings_after: object = None,
) -> Tick:
    """The arguments of :meth:`BatchedPhysicsWorld.drive_tick`, checked against the
    world: one-line errors naming the argument and the first robot at fault.

    Raises:
        TypeError: an argument of the wrong kind (cells or headings not integers,
            fractions not real numbers, ``ended`` not bools, ``tick_steps`` not an
            integer); headings missing for turning robots, or given for robots that do
            not turn.
        ValueError: a wrong shape; ``left`` not each robot's cell
            (:attr:`~BatchedPhysicsWorld.cells`); ``entered`` not that cell or a free
            neighbour of it, or not the cell a robot in mid-move is entering; fractions
            outside ``0 <= before <= after <= 1``, a ``before`` that is not where the last
            tick left the robot, a fraction for a robot with no move (nor turn); ``ended``
            not exactly the robots whose ``after`` is 1; ``tick_steps`` below 1 or above
            ``MAX_STEPS_PER_MOVE``.
            Turning robots: a heading outside 0..3, ``headings_before`` not the heading
            a robot faces (:attr:`~BatchedPhysicsWorld.headings`), ``headings_after``
            neither that nor a quarter turn from it, or not the heading a robot in
            mid-action turns to (:attr:`~BatchedPhysicsWorld.turning_to`); a turn that
            leaves its cell, a move not straight ahead.
    """
    n = world.n_robots
    steps = check_whole("tick_steps", tick_steps, 1, MAX_STEPS_PER_MOVE)
    left = _cells_argument("left", left, n)
    entered = _cells_argument("entered", entered, n)
    before, after = _fraction_argument("before", before, n), _fraction_argument("after", after, n)
    ended = np.asarray(ended)
    if ended.dtype != bool:
        raise TypeError(f"ended must be bools, got {ended.dtype}")
    if ended.shape != (n,):
        raise ValueError(f"ended must have shape ({n},), got {ended.shape}")
    _check_moves(world, left, entered)
    facing, turns = _check_headings(world, left, entered, headings_before, headings_after)
    still = (entered == left).all(axis=1)
    if turns is not None:
        still &= turns == 0
    _check_fractions(world.fractions, still, before, after, ended, world.turning)
    return Tick(entered, before, after, ended, steps, facing, turns)


def _check_headings(
    world: BatchedPhysicsWorld,
    left: np.ndarray,
    entered: np.ndarray,
    headings_before: object,
    headings_after: object,
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Turning robots' headings after their actions and the actions' signed quarter
    turns (``None, None`` for robots that do not turn), or the one-line error of the
    first robot at fault (see :func:`check_tick`)."""
    if not world.turning:
        name = "headings_before" if headings_before is not None else "headings_after"
        if headings_before is not None or headings_after is not None:
            raise TypeError(f"{name}: these robots do not turn (the world has no headings)")
        return None, None
    for name, value in (("headings_before", headings_before), ("headings_after", headings_after)):
        if value is None:
            raise TypeError(f"{name}: turning robots need headings_before and headings_after")
    facing = _headings_argument("headings_before", headings_before, world.n_robots)
    turned_to = _headings_argument("headings_after", headings_after, world.n_robots)
    i = _first(facing != world.headings)
    if i is not None:
        raise ValueError(f"headings_before: robot {i} faces {world.headings[i]}, not {facing[i]}")
    i = _first((turned_to - facing) % 4 == 2)
    if i is not None:
        raise ValueError(
            f"headings_after: robot {i} cannot turn from {facing[i]} to {turned_to[i]} in "
            "one action: a quarter turn at most"
        )
    turns = signed_turns(facing, turned_to)
    moving = (entered != left).any(axis=1)
    i = _first(moving & (turns != 0))
    if i is not None:
        raise ValueError(
            f"entered: robot {i} turns in place (from {facing[i]} to {turned_to[i]}), so it "
            f"cannot enter {_pair(entered[i])} from {_pair(left[i])}"
        )
    ahead = left + HEADING_STEPS[facing]
    i = _first(moving & (entered != ahead).any(axis=1))
    if i is not None:
        raise ValueError(
            f"entered: robot {i} faces heading {facing[i]} and moves only straight "
            f"ahead, to {_pair(ahead[i])}, not {_pair(entered[i])}"
        )
    i = _first((world.fractions > 0) & (turned_to != world.turning_to))
    if i is not None:
        raise ValueError(
            f"headings_after: robot {i} is in mid-action towards heading "
            f"{world.turning_to[i]}, not {turned_to[i]}"
        )
    return turned_to, turns


def _headings_argument(name: str, headings: object, n: int) -> np.ndarray:
    """``headings`` as ``(n,)`` int64 in 0..3, or a one-line error naming ``name``."""
    array = np.asarray(headings)
    if array.dtype.kind not in "iu":
        raise TypeError(f"{name} must be integer headings 0..3, got {array.dtype}")
    if array.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {array.shape}")
    i = _first((array < 0) | (array > 3))
    if i is not None:
        raise ValueError(f"{name}: {array[i]!r} for robot {i} is not a heading 0..3")
    return array.astype(np.int64)


def _check_moves(world: BatchedPhysicsWorld, left: np.ndarray, entered: np.ndarray) -> None:
    """Refuse a ``left`` that is not each robot's cell, an ``entered`` that is neither that
    cell nor a free neighbour, or not the cell a robot in mid-move enters."""
    i = _first((left != world.cells).any(axis=1))
    if i is not None:
        raise ValueError(
            f"left: robot {i} is on (or leaving) {_pair(world.cells[i])}, not {_pair(left[i])}"
        )
    step = np.abs(entered - left).sum(axis=1)
    i = _first((step > 1) | ((step == 1) & ~world.on_free_cells(entered)))
    if i is not None:
        raise ValueError(
            f"entered: robot {i} cannot move from {_pair(left[i])} to "
            f"{_pair(entered[i])}: not a free neighbouring cell"
        )
    i = _first((world.fractions > 0) & (entered != world.entering).any(axis=1))
    if i is not None:
        raise ValueError(
            f"entered: robot {i} is in mid-move into {_pair(world.entering[i])}, "
            f"not {_pair(entered[i])}"
        )


def _check_fractions(
    last: np.ndarray,
    still: np.ndarray,
    before: np.ndarray,
    after: np.ndarray,
    ended: np.ndarray,
    turning: bool = False,
) -> None:
    """Refuse fractions out of order, off where the last tick left the robots, of a robot
    with no move (``still``: nor turn, for ``turning`` robots), or an ended move not done."""
    i = _first((before < 0) | (before > 1))
    if i is not None:
        raise ValueError(f"before: {before[i]!r} for robot {i} is not in [0, 1]")
    i = _first((after < before) | (after > 1))
    if i is not None:
        raise ValueError(
            f"after: {after[i]!r} for robot {i} is not in [before, 1] = [{before[i]!r}, 1]"
        )
    i = _first(np.abs(before - last) > FRACTION_TOLERANCE)
    if i is not None:
        raise ValueError(
            f"before: robot {i}'s move is at {last[i]!r} after the last tick, not {before[i]!r}"
        )
    i = _first(still & (after > 0))
    if i is not None:
        turn = ", headings_after == headings_before" if turning else ""
        raise ValueError(
            f"after: robot {i} has no move (entered == left{turn}) but after = {after[i]!r}"
        )
    i = _first(ended != (after == 1))
    if i is not None:
        raise ValueError(
            f"ended: robot {i}'s move {'ends' if ended[i] else 'does not end'} but its after "
            f"is {after[i]!r}: a move ends exactly when its fraction reaches 1"
        )


def _cells_argument(name: str, cells: object, n: int) -> np.ndarray:
    """``cells`` as ``(n, 2)`` int64, or a one-line error naming ``name``."""
    array = np.asarray(cells)
    if array.dtype.kind not in "iu":
        raise TypeError(f"{name} must be integer (row, col) cells, got {array.dtype}")
    if array.shape != (n, 2):
        raise ValueError(f"{name} must have shape ({n}, 2), got {array.shape}")
    return array.astype(np.int64)


def _fraction_argument(name: str, fraction: object, n: int) -> np.ndarray:
    """``fraction`` as ``(n,)`` finite float64, or a one-line error naming ``name``."""
    array = np.asarray(fraction)
    if array.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be real fractions, got {array.dtype}")
    if array.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {array.shape}")
    array = array.astype(np.float64)
    i = _first(~np.isfinite(array))
    if i is not None:
        raise ValueError(f"{name}: {array[i]!r} for robot {i} is not finite")
    return array


def _first(bad: np.ndarray) -> int | None:
    """The first robot that is ``bad``, or ``None``."""
    return int(np.flatnonzero(bad)[0]) if bad.any() else None


def _pair(cell: np.ndarray) -> tuple[int, ...]:
    return tuple(int(v) for v in cell)


def checked_headings(headings: object, n: int) -> np.ndarray:
    """A batched world's ``headings`` as ``(n,)`` int64 in 0..3 (zeros for ``None``), or a
    ``ValueError``."""
    if headings is None:
        return np.zeros(n, dtype=np.int64)
    array = np.asarray(headings)
    if array.shape != (n,) or array.dtype.kind not in "iu" or ((array < 0) | (array > 3)).any():
        raise ValueError(f"headings must be {n} integers 0..3, got {headings!r}")
    return array.astype(np.int64)
