"""Robots between cells, tick by tick: the physics twin of asynchronous execution.

The executor (:mod:`warehouse_phys.execution.executor`) runs a fleet on a clock of *ticks*:
a move takes ``ticks_needed`` ticks, each tick a robot advances one tick of its move or
holds, and between ticks a robot is at rest on a cell or in mid-move between the cell
it ``left`` and the cell it ``entered``, ``done`` ticks of its move done. Its *nominal
position* [cells, centres at whole ``(row, col)``] is::

    nominal = left + f (entered - left),    f = done / ticks_needed,

and within a tick it moves linearly from the tick's fraction ``before`` to ``after``
(``after == before`` for a robot that holds). A tick is ``tick_steps`` physics steps of
``config.dt``, so a move of ``k`` ticks at full speed crosses a cell in ``k tick_steps``
steps. This module holds that geometry, the tick's argument checks, the body-state I/O
and the controller check for ticks; the driving itself is
:meth:`~warehouse_phys.physics.batched.BatchedPhysicsWorld.drive_tick`.

**Driving.** For the tick, each robot's kinematic control body is placed on the
nominal position at ``before`` and given the segment's velocity
``(after - before)(entered - left) / (tick_steps dt)``; chipmunk carries a kinematic
body along its velocity, so the control body runs along the nominal segment and is on
the nominal position after every physics step (to rounding). The pivot joint matches
the robot's velocity to the control body's (feed-forward) and closes the remaining gap
(its bias, capped at ``max_speed``), with the force capped at ``max_force``. A robot
that holds has a resting control body: the body brakes and holds; a robot at rest
holds its centre. When a move ends, the body is read (the cell whose centre is
nearest) and snapped onto the centre of the cell entered, at rest, with its control
body: the only teleport, as in a lock-step move.

**Tracking error.** ``e`` is the largest distance, at any physics step, between a
body's centre and its nominal position. A body starts every move at rest, while its
control body already moves: chipmunk moves bodies before it solves the joint, so the
body is a full step behind at the first step, and ``e`` is at least the distance a
move covers in one step, ``1 / (ticks_needed tick_steps)`` cells; a stop makes the body
brake and overshoot. :func:`check_tick_controller` measures ``e`` on probe motions
(full-speed moves in a row, corners, reversals after rest, stops of one to many ticks
at every fraction of a move, stop-and-go patterns, slower robots) and refuses settings
that cannot keep their promises.

**The clearance formula for robots in mid-move.** Let ``p_i`` be robot ``i``'s
nominal position and ``b_i`` its body's centre after a physics step. The executor
keeps ``|p_i - p_j| >= g`` (its ``min_gap``, ``0 < g <= 1``) at every instant, nominal
positions moving linearly within a tick, so at every physics step too. The controller
keeps ``|b_i - p_i| <= e`` there, and we allow ``e + m`` for histories the probes do
not try (:data:`TRACKING_MARGIN` ``m``). By the triangle inequality::

    |b_i - b_j| >= |p_i - p_j| - |b_i - p_i| - |b_j - p_j| >= g - 2 (e + m).

Chipmunk finds contacts only at physics steps, from the positions there, and leaves an
overlap of up to its collision slop ``s`` uncorrected (``COLLISION_SLOP`` cells: the
engine sets ``space.collision_slop = COLLISION_SLOP x cell_size``), the bound every
physics fleet's tests hold bodies to (a gap above ``-s``). Discs of diameter ``d``
[cells] therefore never overlap by more than ``s`` when::

    g - 2 (e + m) >= d - s,   that is   g >= d - s + 2 (e + m),

the smallest executor ``min_gap`` the physics twin accepts (:func:`required_min_gap`).
A setting for which this exceeds 1 cannot be run (the executor's gap is at most one
cell). Walls and shelves stand at least half a cell from every nominal position (the
segment joins two free cells' centres), so ``e < 0.5 - r`` (radius ``r`` [cells]) also
keeps every disc off them: :func:`check_tick_controller` refuses a larger ``e``.

**Turning robots.** A world built with ``headings`` (the League of Robot Runners'
robots: an *action* is a forward move along the heading or a quarter turn in place, each
taking ``ticks_needed`` ticks) is driven the same way, and its angles too.
:meth:`~warehouse_phys.physics.batched.BatchedPhysicsWorld.drive_tick` then takes the
heading each robot faces at the start and at the end of its action (``headings_before``,
``headings_after``: the same for a forward move, a quarter turn apart for a turn, whose
``entered`` is the cell ``left``), and a robot's *nominal angle* [rad] is::

    angle = h_before QUARTER + f turn QUARTER,    turn = 1 (clockwise), -1 or 0,

(:func:`nominal_angles`; heading ``h`` lies at ``h QUARTER``, as the batched world builds
and snaps bodies, so a counter-clockwise turn from east runs to ``-QUARTER`` and is
snapped onto north's ``3 QUARTER``, the same bearing). Within a tick the control body
turns at a constant spin from the nominal angle at ``before`` to the one at ``after``
(chipmunk carries a kinematic body's angle along its spin as it carries its position
along its velocity) and the gear joint turns the body after it, with the pivot joint's
limits at the disc's rim. During a turn the control body rests on the cell's centre and
the pivot joint holds the body's centre there: a turn's nominal position is that centre,
so any motion of the body's centre during a turn counts in ``e``. When an action ends,
the heading is read from the body's angle (the nearest quarter turn) and the body is
snapped onto the angle of ``h_after`` with its position. A body starts every turn at
rest, a step behind its control body, so the largest distance from the nominal angle
(``TickMotion.angle_error``) is at least ``QUARTER / (ticks_needed tick_steps)`` rad.
:func:`check_tick_controller` with ``turning=True`` measures it, the centres' motion and
the angle's distance from the heading at the snap, on probes of quarter turns both ways
in a row, forward moves after turns, U-turns and stops at every share of a turn, and
refuses a setting whose actions end more than half of ``HEADING_SNAP_BOUND`` off their
heading. A disc's angle moves no part of it nearer another disc or a wall, so the
clearance formula above holds for turning robots with their ``e``
(``required_min_gap(..., turning=True)``).

Its length is one model, robots between cells: the geometry, the checks of a tick's
arguments, and the probes whose measurements the clearance formula rests on; split, the
derivation above would rest on two modules.
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pymunk
import pymunk.batch

from warehouse_phys.execution.async_grid import AsyncGrid
from warehouse_phys.execution.ticks import check_ticks_per_move, check_whole
from warehouse_phys.physics.config import (
    HEADING_SNAP_BOUND,
    MAX_STEPS_PER_MOVE,
    SNAP_ERROR_BOUND,
    PhysicsConfig,
)
from warehouse_phys.physics.engine import new_space
from warehouse_phys.world.grid import ACTION_DELTAS, WarehouseGrid
from warehouse_phys.world.headings import HEADING_MOVES, TurnAction, turned

if TYPE_CHECKING:
    from warehouse_phys.physics.batched import BatchedPhysicsWorld

#: Room allowed beyond the measured tracking error, for command histories the probes
#: do not try [cells]: each body is taken to be within ``e + TRACKING_MARGIN`` of its
#: nominal position.
TRACKING_MARGIN = 0.01
#: Share of ``max_speed`` a move may reach with the default ``tick_steps``
#: (:func:`default_tick_steps`); the rest is the controller's room to catch up [1].
DEFAULT_SPEED_SHARE = 0.25
#: Fewest physics steps of a default tick: a body that starts a move's last tick from
#: rest then catches up with its nominal position before the tick ends (with two steps
#: it may end more than half the snap bound from the centre).
DEFAULT_LEAST_TICK_STEPS = 3
#: A tick's ``before`` may differ from the fraction the last tick left by this much.
FRACTION_TOLERANCE = 1e-9
#: Position, velocity and spin of a body in pymunk's batched I/O (5 numbers a body).
STATE_FIELDS = (
    pymunk.batch.BodyFields.POSITION
    | pymunk.batch.BodyFields.VELOCITY
    | pymunk.batch.BodyFields.ANGULAR_VELOCITY
)
#: The same with the angle, for turning robots (6 numbers a body: x, y, angle, vx, vy, spin).
TURNING_STATE_FIELDS = STATE_FIELDS | pymunk.batch.BodyFields.ANGLE
#: A quarter turn [rad]: a turning robot facing heading ``h`` (quarter turns clockwise
#: from east, rows growing southwards) has its body at the angle ``h QUARTER``.
QUARTER = math.pi / 2
#: The ``(d_row, d_col)`` of a forward move along each heading.
HEADING_STEPS = np.array(ACTION_DELTAS, dtype=np.int64)[HEADING_MOVES]
HEADING_STEPS.flags.writeable = False


class TickMotion(NamedTuple):
    """How closely bodies follow their nominal positions (and turning bodies their
    nominal angles) tick by tick, the largest over every probe
    :func:`check_tick_controller` tries."""

    #: ``e``: the largest distance from a body's centre to its nominal position, at
    #: any physics step [cells] (a turning robot's nominal position during a turn is
    #: its cell's centre: the centre's motion counts).
    tracking_error: float
    #: The largest part of that distance across the move's direction (all of it during
    #: a turn) [cells].
    drift: float
    #: The largest distance from a body to the centre it is snapped onto at a move's
    #: end [cells].
    snap_error: float
    #: The nominal speed of the fastest probe, a move of ``ticks_per_move`` ticks [m/s].
    speed: float
    #: The largest angle between a turning body and its nominal angle at any physics
    #: step [rad]; 0 unless turning robots were probed.
    angle_error: float = 0.0
    #: The largest angle between a turning body and the heading it is snapped onto at
    #: an action's end [rad]; 0 unless turning robots were probed.
    heading_error: float = 0.0


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


# ---------------------------------------------------------------------- geometry
def default_tick_steps(config: PhysicsConfig, ticks_per_move: int) -> int:
    """The default physics steps of a tick: the fewest for a move of ``ticks_per_move``
    ticks to be no faster than :data:`DEFAULT_SPEED_SHARE` of ``max_speed``, and at
    least :data:`DEFAULT_LEAST_TICK_STEPS`.

    The default robot (6 m/s, 1/60 s steps) then crosses a cell in 40 steps at 10 ticks a
    move (4 steps a tick, 1.5 m/s) and in 42 at 3 (14 steps a tick, 1.43 m/s).
    """
    ticks = check_ticks_per_move(ticks_per_move)
    fastest = DEFAULT_SPEED_SHARE * config.max_speed * config.dt * ticks  # [m] a tick's step
    return max(DEFAULT_LEAST_TICK_STEPS, math.ceil(config.cell_size / fastest * (1 - 1e-12)))


def nominal_speed(config: PhysicsConfig, ticks_needed: int, tick_steps: int) -> float:
    """The speed of a move of ``ticks_needed`` ticks of ``tick_steps`` steps [m/s]."""
    return config.cell_size / (ticks_needed * tick_steps * config.dt)


def tick_fractions(
    done_before: np.ndarray, done_after: np.ndarray, ended: np.ndarray, ticks_needed: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Each robot's fraction of its move done before and after a tick (``before``,
    ``after`` of :meth:`BatchedPhysicsWorld.drive_tick`), from the ticks done before and
    after it (``Executor.done``, ``AsyncGrid.done``), the moves that ended in it (their
    ``done`` is back to 0; their fraction is 1) and the ticks each move takes."""
    needed = np.asarray(ticks_needed, dtype=np.float64)
    after = np.where(ended, 1.0, np.asarray(done_after) / needed)
    return np.asarray(done_before) / needed, after


def nominal_positions(left: np.ndarray, entered: np.ndarray, fraction: np.ndarray) -> np.ndarray:
    """``(N, 2)`` nominal positions ``left + fraction (entered - left)`` [cells], from
    ``(N, 2)`` cells ``(row, col)`` and ``(N,)`` fractions (any trailing shape of
    ``fraction`` broadcasts: ``(N, k)`` gives ``(N, k, 2)``)."""
    left = np.asarray(left, dtype=np.float64)
    delta = np.asarray(entered, dtype=np.float64) - left
    fraction = np.asarray(fraction, dtype=np.float64)
    extra = (slice(None),) + (None,) * (fraction.ndim - 1)
    return left[extra] + fraction[..., None] * delta[extra]


def tracking_errors(
    paths: np.ndarray, left: np.ndarray, entered: np.ndarray, before: np.ndarray, after: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """How far each body was from its nominal position after each physics step of a
    tick, and how far across its move [cells]: two ``(N, tick_steps)`` arrays.

    ``paths`` is :attr:`BatchedPhysicsWorld.last_paths` of the tick (``(N, tick_steps,
    2)``); the other arguments are the tick's (:meth:`BatchedPhysicsWorld.drive_tick`).
    """
    steps = paths.shape[1]
    share = np.arange(1, steps + 1) / steps
    fraction = before[:, None] + (after - before)[:, None] * share[None, :]
    offset = paths - nominal_positions(left, entered, fraction)
    delta = (np.asarray(entered) - np.asarray(left)).astype(np.float64)  # unit or zero
    across = np.abs(offset[..., 0] * delta[:, None, 1] - offset[..., 1] * delta[:, None, 0])
    return np.sqrt((offset * offset).sum(axis=2)), across


def control_motion(
    left_xy: np.ndarray,
    entered_xy: np.ndarray,
    before: np.ndarray,
    after: np.ndarray,
    duration: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Each control body's place at the tick's start [m] and its velocity through the
    tick [m/s]: from the centres ``(x, y)`` of the cells left and entered, the tick's
    fractions and its ``duration`` [s]."""
    delta = entered_xy - left_xy
    return left_xy + before[:, None] * delta, ((after - before) / duration)[:, None] * delta


def signed_turns(headings_before: np.ndarray, headings_after: np.ndarray) -> np.ndarray:
    """``(N,)`` int64 quarter turns of each action, from the headings (0..3) it starts
    and ends facing, at most a quarter turn apart: 1 clockwise, -1 counter-clockwise,
    0 for a forward move or none."""
    change = (np.asarray(headings_after, dtype=np.int64) - headings_before) % 4
    return np.where(change == 3, -1, change)


def nominal_angles(
    headings_before: np.ndarray, headings_after: np.ndarray, fraction: np.ndarray
) -> np.ndarray:
    """Turning robots' nominal angles [rad]: ``headings_before QUARTER + fraction turn
    QUARTER`` with ``turn`` the action's :func:`signed_turns`, from ``(N,)`` headings
    and ``(N,)`` fractions (``(N, k)`` fractions give ``(N, k)``). The angle of heading
    ``h`` is ``h QUARTER``, as the batched world builds and snaps bodies, so a turn
    counter-clockwise from east runs to ``-QUARTER``, north's angle less a full turn."""
    start = np.asarray(headings_before, dtype=np.int64) * QUARTER
    turn = signed_turns(headings_before, headings_after) * QUARTER
    fraction = np.asarray(fraction, dtype=np.float64)
    extra = (slice(None),) + (None,) * (fraction.ndim - 1)
    return start[extra] + fraction * turn[extra]


def angle_errors(
    orientations: np.ndarray,
    headings_before: np.ndarray,
    headings_after: np.ndarray,
    before: np.ndarray,
    after: np.ndarray,
) -> np.ndarray:
    """How far each turning body's angle was from its nominal angle after each physics
    step of a tick [rad]: ``(N, tick_steps)``.

    ``orientations`` is :attr:`BatchedPhysicsWorld.last_orientations` of the tick
    (``(N, tick_steps)`` quarter turns); the other arguments are the tick's
    (:meth:`BatchedPhysicsWorld.drive_tick`).
    """
    steps = orientations.shape[1]
    share = np.arange(1, steps + 1) / steps
    fraction = before[:, None] + (after - before)[:, None] * share[None, :]
    nominal = nominal_angles(headings_before, headings_after, fraction)
    return np.abs(np.asarray(orientations) * QUARTER - nominal)


def control_turn(
    headings_before: np.ndarray,
    turns: np.ndarray,
    before: np.ndarray,
    after: np.ndarray,
    duration: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Each turning robot's control body's angle at the tick's start [rad] and its spin
    through the tick [rad/s], from the headings its actions start facing, their
    :func:`signed_turns`, the tick's fractions and its ``duration`` [s]."""
    turn = turns * QUARTER
    return headings_before * QUARTER + before * turn, (after - before) / duration * turn


# ---------------------------------------------------------------------- checks
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
        ValueError: a wrong shape; ``left`` not each robot's cell (:attr:`cells`);
            ``entered`` not that cell or a free neighbour of it, or not the cell a robot
            in mid-move is entering; fractions outside ``0 <= before <= after <= 1``,
            a ``before`` that is not where the last tick left the robot, a fraction for
            a robot with no move (nor turn); ``ended`` not exactly the robots whose
            ``after`` is 1; ``tick_steps`` below 1 or above ``MAX_STEPS_PER_MOVE``.
            Turning robots: a heading outside 0..3, ``headings_before`` not the heading
            a robot faces (:attr:`headings`), ``headings_after`` neither that nor a
            quarter turn from it, or not the heading a robot in mid-action turns to
            (:attr:`turning_to`); a turn that leaves its cell, a move not straight ahead.
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


# ---------------------------------------------------------------------- body states
class BodyStates:
    """Every body's position, velocity and spin (and angle, with ``angles=True``), read
    and written with one batched call each (:func:`pymunk.batch.get_space_bodies`,
    :func:`pymunk.batch.set_space_bodies`).

    :attr:`array` is ``(bodies, 5)``: ``x, y`` [m], ``vx, vy`` [m/s], spin [rad/s], in
    the space's order (``(bodies, 6)`` with the angle [rad] after ``x, y``); the views
    :attr:`positions`, :attr:`angles`, :attr:`velocities` and :attr:`spins` name its
    columns. It lives in our memory, with room for more numbers than the bodies need
    (pymunk's buffer grows, and would move, when fewer than three places are left); no
    body is ever added to a world's space after it is built.
    """

    def __init__(self, n_bodies: int, *, angles: bool = False) -> None:
        self.n_bodies = n_bodies
        width = 6 if angles else 5
        self._fields = TURNING_STATE_FIELDS if angles else STATE_FIELDS
        self._floats = np.zeros(width * n_bodies + 8)
        #: The states read last, or to be written.
        self.array = self._floats[: width * n_bodies].reshape(n_bodies, width)
        #: Views of :attr:`array`: ``(bodies, 2)`` positions [m], ``(bodies,)`` angles
        #: [rad] (``None`` without ``angles``), ``(bodies, 2)`` velocities [m/s] and
        #: ``(bodies,)`` spins [rad/s].
        self.positions = self.array[:, :2]
        self.angles = self.array[:, 2] if angles else None
        self.velocities = self.array[:, width - 3 : width - 1]
        self.spins = self.array[:, width - 1]
        self._buffer = pymunk.batch.Buffer()
        self._buffer.set_float_buf(self._floats)

    def read(self, space: pymunk.Space) -> np.ndarray:
        """Read every body's state into :attr:`array`; returns it."""
        self._buffer.clear()
        pymunk.batch.get_space_bodies(space, self._fields, self._buffer)
        if len(self._buffer.float_buf()) != 8 * self.array.size:  # pragma: no cover
            raise RuntimeError(f"the space no longer holds {self.n_bodies} bodies")
        return self.array

    def write(self, space: pymunk.Space) -> None:
        """Give every body the state in :attr:`array` (a state as read is kept exactly)."""
        pymunk.batch.set_space_bodies(space, self._fields, self._buffer)


# ---------------------------------------------------------------------- the controller check
def check_tick_controller(
    config: PhysicsConfig,
    ticks_per_move: int,
    tick_steps: int | None = None,
    *,
    turning: bool = False,
) -> TickMotion:
    """Refuse a setting whose bodies could not follow their nominal positions tick by
    tick; measure how closely they do (:class:`TickMotion`).

    Args:
        config: The physical parameters (the lock-step check,
            :func:`~warehouse_phys.physics.check_controller`, is separate).
        ticks_per_move: The fewest ticks any robot's move takes (the fastest robot's
            ``ticks_needed``); slower robots are probed too (twice as many ticks).
        tick_steps: Physics steps in a tick (default :func:`default_tick_steps`).
        turning: Also probe turning robots (a fleet of them): the answer is then the
            largest over both kinds of probe, with the angles measured.

    The probes (see ``_probe_patterns``) run single robots, each on its own copy of a
    5 x 5 floor with a shelf, through :class:`~warehouse_phys.execution.async_grid.AsyncGrid`
    and :meth:`BatchedPhysicsWorld.drive_tick`: moves in a row round the walls and the
    shelf (corners, every direction), reversals after rest, stops of 1, 2, 3, 5 and
    ``ticks_per_move`` ticks after every number of a move's ticks (at 32 points spread
    over longer moves), stop-and-go patterns and seeded random ones. Turning robots
    (``_TURN_ROUTES``) make quarter turns both ways in a row, forward moves after turns
    round the shelf, and U-turns both ways, with the same patterns of stops on every
    action of the last route (so at every share of a turn). The errors are measured
    after every physics step. The answer for a setting is cached.

    Raises:
        TypeError, ValueError: ``ticks_per_move`` or ``tick_steps`` not an integer in
            range; ValueError, naming the setting, with advice: a move faster than
            ``max_speed``, a body that strays half a cell less its radius from its
            nominal position (its disc could touch a wall; a turning body's centre is to
            hold its cell's centre), that ends on another cell (or heading), or that
            ends farther than half of ``SNAP_ERROR_BOUND`` from its centre (half of
            ``HEADING_SNAP_BOUND`` from its heading).
    """
    ticks = check_ticks_per_move(ticks_per_move)
    steps = default_tick_steps(config, ticks) if tick_steps is None else tick_steps
    steps = check_whole("tick_steps", steps, 1, MAX_STEPS_PER_MOVE)
    return (
        _checked_turning(config, ticks, steps) if turning else _checked_motion(config, ticks, steps)
    )


@functools.cache
def _checked_motion(config: PhysicsConfig, ticks: int, steps: int) -> TickMotion:
    """:func:`check_tick_controller` for checked arguments (cached)."""
    setting = _setting(config, ticks, steps)
    speed = nominal_speed(config, ticks, steps)
    if speed > config.max_speed * (1 + 1e-12):  # (a move exactly at max_speed may round up)
        fewest = math.ceil(config.cell_size / (config.max_speed * steps * config.dt) - 1e-9)
        raise ValueError(
            f"{setting} moves a robot a cell in {ticks * steps * config.dt:.3g} s, "
            f"{speed:.3g} m/s, faster than max_speed {config.max_speed:g} m/s; use at least "
            f"{fewest} ticks a move, more tick_steps or a higher max_speed"
        )
    error, drift, snap, wrong = _run_probes(config, ticks, steps)
    _refuse_strays(config, setting, error, snap, wrong and f"a probe's move {wrong}")
    return TickMotion(error, drift, snap, speed)


@functools.cache
def _checked_turning(config: PhysicsConfig, ticks: int, steps: int) -> TickMotion:
    """:func:`check_tick_controller` with ``turning=True``, for checked arguments (cached).

    A turn is no harder to follow than a move: the gear joint has the pivot joint's
    limits at the disc's rim, and a turn moves the rim ``QUARTER r < 1`` cell."""
    motion = _checked_motion(config, ticks, steps)
    setting = _setting(config, ticks, steps)
    error, drift, snap, angle, heading, wrong = _run_turning_probes(config, ticks, steps)
    _refuse_strays(config, setting, error, snap, wrong and f"a turning probe's {wrong}")
    if not heading < HEADING_SNAP_BOUND / 2:
        raise ValueError(
            f"with {setting} a turning robot's action ends {heading:.3g} rad off its heading, "
            f"not within half the bound of {HEADING_SNAP_BOUND}; {_ADVICE}"
        )
    return TickMotion(
        max(error, motion.tracking_error), max(drift, motion.drift),
        max(snap, motion.snap_error), motion.speed, angle, heading,
    )  # fmt: skip


#: What to change when the bodies cannot follow.
_ADVICE = "use more ticks a move or tick_steps, or raise max_force or gain"


def _setting(config: PhysicsConfig, ticks: int, steps: int) -> str:
    return f"ticks_per_move {ticks} with tick_steps {steps} (dt={config.dt:g} s)"


def _refuse_strays(
    config: PhysicsConfig, setting: str, error: float, snap: float, wrong: str
) -> None:
    """Refuse probes that ended an action ``wrong`` (a description, empty if none), or
    whose bodies strayed ``error`` too far from their nominal positions or ended ``snap``
    too far from their centres [cells]."""
    room = 0.5 - config.robot_radius / config.cell_size
    if wrong:
        raise ValueError(f"with {setting} {wrong}: the body lags too far; {_ADVICE}")
    if not error < room:
        raise ValueError(
            f"with {setting} a body strays {error:.3g} cells from its nominal position, not "
            f"less than half a cell less its radius ({room:.3g}): it could touch a wall; "
            f"{_ADVICE}"
        )
    if not snap < SNAP_ERROR_BOUND / 2:
        raise ValueError(
            f"with {setting} a move ends {snap:.3g} cells from the centre, not within half the "
            f"bound of {SNAP_ERROR_BOUND}; {_ADVICE}"
        )


def required_min_gap(
    config: PhysicsConfig,
    ticks_per_move: int,
    tick_steps: int | None = None,
    *,
    turning: bool = False,
) -> float:
    """The smallest executor ``min_gap`` [cells] whose moves the physics twin runs with no
    contact deeper than the collision slop: ``d - s + 2 (e + TRACKING_MARGIN)`` (see the
    module), with ``e`` from :func:`check_tick_controller` (same arguments; for a fleet
    of turning robots ``turning=True``, whose ``e`` also counts centres during turns).

    Raises:
        ValueError: as :func:`check_tick_controller`, or naming the setting when no
            ``min_gap`` of at most one cell is enough.
    """
    motion = check_tick_controller(config, ticks_per_move, tick_steps, turning=turning)
    slop = new_space(config).collision_slop / config.cell_size  # [cells], as the engine sets it
    reach = motion.tracking_error + TRACKING_MARGIN
    gap = config.robot_diameter - slop + 2 * reach
    if gap > 1:
        steps = default_tick_steps(config, ticks_per_move) if tick_steps is None else tick_steps
        raise ValueError(
            f"with ticks_per_move {ticks_per_move} and tick_steps {steps} bodies stray up to "
            f"{reach:.3g} cells (with the margin) from their nominal positions, so robots of "
            f"diameter {config.robot_diameter:.3g} need a min_gap of {gap:.3g} cells, more "
            "than one: use more ticks a move or tick_steps, smaller robots, or raise "
            "max_force or gain"
        )
    return gap


#: The check's floor: open cells beside walls and round a shelf.
_PROBE_FLOOR = WarehouseGrid.from_layout([".....", ".....", "...#.", ".....", "....."])
#: (start, moves) the probe robots make: a loop round the floor's walls (four straight
#: runs, four corners), a loop round the shelf (corners beside it), and a square with
#: reversals (every direction after every other).
_PROBE_ROUTES: tuple[tuple[tuple[int, int], tuple[int, ...]], ...] = (
    ((0, 0), (2, 2, 2, 2, 1, 1, 1, 1, 0, 0, 0, 0, 3, 3, 3, 3)),
    ((1, 2), (2, 2, 1, 1, 0, 0, 3, 3)),
    ((1, 1), (2, 1, 0, 3, 2, 0, 1, 3)),
)
#: Stop lengths the probes try after every number of a move's ticks [ticks] (and one
#: of ``ticks_per_move`` ticks, long enough to come to rest).
_STOP_TICKS = (1, 2, 3, 5)
#: Most points of a move at which the probes stop (spread evenly over a long move).
_MOST_STOPS = 32
#: Seeded random stop-and-go patterns, and their chance of GO a tick.
_RANDOM_PATTERNS, _RANDOM_GO = 8, 0.6


def _probe_patterns(ticks: int) -> list[tuple[int, int, np.ndarray]]:
    """``(route, ticks_needed, pattern)`` of each probe robot: ``pattern[q]`` is the GO of
    the ``q``-th tick since its current move (or action) could start (True beyond its
    end); ``route`` indexes ``_PROBE_ROUTES`` or ``_TURN_ROUTES`` (three routes each).

    Full speed on every route, for robots of ``ticks`` and ``2 ticks`` ticks a move;
    on the last route (the square with reversals; turns both ways): stops of each of
    ``_STOP_TICKS`` and of ``ticks`` ticks after every number of a move's ticks (after
    none: a start after rest), GO STOP and GO STOP STOP alternating, seeded random
    patterns, and slower robots stopped halfway.
    """
    go = np.ones(1, dtype=bool)
    plans = [(route, k, go) for route in range(len(_PROBE_ROUTES)) for k in (ticks, 2 * ticks)]
    points = np.unique(np.linspace(0, ticks - 1, min(ticks, _MOST_STOPS)).round().astype(int))
    for done in points.tolist():
        for length in sorted({*_STOP_TICKS, ticks}):
            plans.append((2, ticks, np.repeat([True, False, True], [done, length, ticks - done])))
    for cycle in ([True, False], [True, False, False]):
        plans.append((2, ticks, np.tile(cycle, ticks)))
    rng = np.random.default_rng(0)
    plans += [(2, ticks, rng.random(4 * ticks) < _RANDOM_GO) for _ in range(_RANDOM_PATTERNS)]
    plans += [(2, 2 * ticks, np.repeat([True, False, True], [ticks, n, ticks])) for n in (1, 3)]
    return plans


class _Plans(NamedTuple):
    """The probe robots' plans as arrays (see :func:`_plan_arrays`)."""

    route_of: np.ndarray  # (R,) each robot's route
    needed: np.ndarray  # (R,) its ticks a move
    patterns: np.ndarray  # (R, width) its GO a tick since its current move could start
    actions: np.ndarray  # (R, longest) its route's moves or actions, padded with zeros
    counts: np.ndarray  # (R,) how many its route has


def _plan_arrays(
    plans: list[tuple[int, int, np.ndarray]], routes: tuple[tuple[int, ...], ...]
) -> _Plans:
    """:func:`_probe_patterns`'s plans as arrays, over ``routes``' moves (or actions)."""
    route_of = np.array([route for route, _, _ in plans])
    needed = np.array([k for _, k, _ in plans], dtype=np.int64)
    width = max(len(pattern) for _, _, pattern in plans)
    patterns = np.ones((len(plans), width), dtype=bool)
    for row, (_, _, pattern) in enumerate(plans):
        patterns[row, : len(pattern)] = pattern
    longest = max(len(route) for route in routes)
    actions = np.array([routes[r] + (0,) * (longest - len(routes[r])) for r in route_of])
    counts = np.array([len(routes[r]) for r in route_of])
    return _Plans(route_of, needed, patterns, actions, counts)


def _run_probes(config: PhysicsConfig, ticks: int, steps: int) -> tuple[float, float, float, str]:
    """Run the probes; the largest tracking error, sideways drift and snap error [cells],
    and the first move read on another cell than the grid twin's (empty if none)."""
    from warehouse_phys.physics.batched import BatchedPhysicsWorld

    plans = _plan_arrays(_probe_patterns(ticks), tuple(moves for _, moves in _PROBE_ROUTES))
    moves, patterns, needed, cols = plans.actions, plans.patterns, plans.needed, _PROBE_FLOOR.cols
    starts = np.array([_PROBE_ROUTES[r][0] for r in plans.route_of], dtype=np.int64)
    world = BatchedPhysicsWorld(_PROBE_FLOOR, config, starts, record_path=True)
    twin = AsyncGrid(_PROBE_FLOOR, starts[:, 0] * cols + starts[:, 1], needed)
    deltas = np.array(ACTION_DELTAS, dtype=np.int64)
    robots = np.arange(len(needed))
    since, made = np.zeros(len(needed), dtype=np.int64), np.zeros(len(needed), dtype=np.int64)
    error = drift = snap = 0.0
    while (made < plans.counts).any():
        pending = made < plans.counts
        step = deltas[moves[robots, np.minimum(made, moves.shape[1] - 1)]]
        aim = twin.left + np.where(pending, step[:, 0] * cols + step[:, 1], 0)
        heading = np.where(twin.done > 0, twin.entered, aim)
        go = patterns[robots, np.minimum(since, patterns.shape[1] - 1)] & pending
        left, done = _rows_cols(twin.left, cols), twin.done.copy()
        ended = twin.step(go, heading)
        entered = _rows_cols(twin.entered, cols)
        before, after = tick_fractions(done, twin.done, ended, needed)
        cells, errors = world.drive_tick(left, entered, before, after, ended, steps)
        wrong = np.flatnonzero((cells != entered[ended]).any(axis=1))
        if len(wrong):
            i, read = int(np.flatnonzero(ended)[wrong[0]]), _pair(cells[wrong[0]])
            move = f"from {_pair(left[i])} to {_pair(entered[i])} ends on {read}"
            return error, drift, snap, move
        off, across = tracking_errors(world.last_paths, left, entered, before, after)
        error, drift = max(error, float(off.max())), max(drift, float(across.max()))
        snap = max(snap, float(errors.max(initial=0.0)))
        since = np.where(ended, 0, since + 1)
        made += ended
    return error, drift, snap, ""


#: (start, heading, actions) the turning probe robots make (``TurnAction``: 0 forward,
#: 1 clockwise, 2 counter-clockwise): quarter turns both ways in a row (a full round
#: each way); a loop round the shelf, clockwise turns each followed by forward moves;
#: a square with counter-clockwise turns, then U-turns both ways, each followed by a
#: forward move. The last is the route the stop patterns run on.
_TURN_ROUTES: tuple[tuple[tuple[int, int], int, tuple[int, ...]], ...] = (
    ((2, 2), 0, (1, 1, 1, 1, 2, 2, 2, 2)),
    ((1, 2), 0, (0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1)),
    ((1, 1), 0, (0, 2, 0, 2, 0, 2, 0, 2, 1, 1, 0, 2, 2, 0)),
)


def _run_turning_probes(
    config: PhysicsConfig, ticks: int, steps: int
) -> tuple[float, float, float, float, float, str]:
    """Run the turning robots' probes; the largest tracking error, drift (during a turn
    the whole distance from the centre) and snap error [cells], angle error and heading
    error [rad], and the first action read on another cell or heading (empty if none)."""
    from warehouse_phys.physics.batched import BatchedPhysicsWorld

    plans = _plan_arrays(_probe_patterns(ticks), tuple(route for *_, route in _TURN_ROUTES))
    actions, patterns, needed = plans.actions, plans.patterns, plans.needed
    cells = np.array([_TURN_ROUTES[r][0] for r in plans.route_of], dtype=np.int64)
    facing = np.array([_TURN_ROUTES[r][1] for r in plans.route_of], dtype=np.int64)
    world = BatchedPhysicsWorld(_PROBE_FLOOR, config, cells, record_path=True, headings=facing)
    robots, found = np.arange(len(needed)), np.zeros(5)
    done, since, made = (np.zeros(len(needed), dtype=np.int64) for _ in range(3))
    while (made < plans.counts).any():
        pending = made < plans.counts
        action = actions[robots, np.minimum(made, actions.shape[1] - 1)]
        action = np.where(pending, action, TurnAction.WAIT)
        turned_to = turned(facing, action)
        forward = (action == TurnAction.FORWARD)[:, None]
        entered = cells + np.where(forward, HEADING_STEPS[facing], 0)
        advanced = done + (patterns[robots, np.minimum(since, patterns.shape[1] - 1)] & pending)
        ended = advanced == needed
        before, after = tick_fractions(done, np.where(ended, 0, advanced), ended, needed)
        read, snaps = world.drive_tick(
            cells, entered, before, after, ended, steps,
            headings_before=facing, headings_after=turned_to,
        )  # fmt: skip
        wrong = _first(
            (read != entered[ended]).any(axis=1) | (world.read_headings != turned_to[ended])
        )
        if wrong is not None:
            i = int(np.flatnonzero(ended)[wrong])
            action_name = f"{TurnAction(action[i]).name} from {_pair(cells[i])} facing {facing[i]}"
            read_as = f"{_pair(read[wrong])} facing {world.read_headings[wrong]}"
            return (*found.tolist(), f"{action_name} ends on {read_as}")
        off, across = tracking_errors(world.last_paths, cells, entered, before, after)
        angle = angle_errors(world.last_orientations, facing, turned_to, before, after)
        drift = np.where((turned_to != facing)[:, None], off, across)
        found = np.maximum(found, [off.max(), drift.max(), snaps.max(initial=0.0), angle.max(),
                                   world.heading_errors.max(initial=0.0)])  # fmt: skip
        cells = np.where(ended[:, None], entered, cells)
        facing = np.where(ended, turned_to, facing)
        done, since = np.where(ended, 0, advanced), np.where(ended, 0, since + 1)
        made += ended
    return (*found.tolist(), "")


def _rows_cols(cells: np.ndarray, cols: int) -> np.ndarray:
    """``(N, 2)`` ``(row, col)`` of ``(N,)`` cell indices."""
    return np.stack(np.divmod(cells, cols), axis=1)
