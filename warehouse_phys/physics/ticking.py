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
steps. This module holds that geometry and the drive of the batched world's bodies
through a tick (:func:`aim_controls`, :func:`snap_ended`), which
:meth:`~warehouse_phys.physics.batched.BatchedPhysicsWorld.drive_tick` runs; a tick's
arguments are checked by :mod:`~warehouse_phys.physics.tick_arguments`, and the probes that
measure the tracking error below and the ``min_gap`` of the clearance formula are
:mod:`~warehouse_phys.physics.tick_controller`'s (``check_tick_controller``,
``required_min_gap``).

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
brake and overshoot. ``check_tick_controller`` measures ``e`` on probe motions
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

the smallest executor ``min_gap`` the physics twin accepts (``required_min_gap``).
A setting for which this exceeds 1 cannot be run (the executor's gap is at most one
cell). Walls and shelves stand at least half a cell from every nominal position (the
segment joins two free cells' centres), so ``e < 0.5 - r`` (radius ``r`` [cells]) also
keeps every disc off them: ``check_tick_controller`` refuses a larger ``e``.

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
``check_tick_controller`` with ``turning=True`` measures it, the centres' motion and
the angle's distance from the heading at the snap, on probes of quarter turns both ways
in a row, forward moves after turns, U-turns and stops at every share of a turn, and
refuses a setting whose actions end more than half of ``HEADING_SNAP_BOUND`` off their
heading. A disc's angle moves no part of it nearer another disc or a wall, so the
clearance formula above holds for turning robots with their ``e``
(``required_min_gap(..., turning=True)``).

The derivation stays here whole, beside the geometry it rests on; the functions that
measure ``e`` and apply the formula are :mod:`~warehouse_phys.physics.tick_controller`'s.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from warehouse_phys.execution.ticks import check_ticks_per_move
from warehouse_phys.physics.body_io import (
    STATE_FIELDS,
    TURNING_STATE_FIELDS,
    BodyStates,
    check_angles,
)
from warehouse_phys.physics.config import PhysicsConfig
from warehouse_phys.world.grid import ACTION_DELTAS
from warehouse_phys.world.headings import HEADING_MOVES

if TYPE_CHECKING:
    from warehouse_phys.physics.batched import BatchedPhysicsWorld
    from warehouse_phys.physics.tick_arguments import Tick

__all__ = [
    "DEFAULT_LEAST_TICK_STEPS",
    "DEFAULT_SPEED_SHARE",
    "HEADING_STEPS",
    "QUARTER",
    "STATE_FIELDS",
    "TRACKING_MARGIN",
    "TURNING_STATE_FIELDS",
    "BodyStates",
    "aim_controls",
    "angle_errors",
    "control_motion",
    "control_turn",
    "default_tick_steps",
    "drive_executor_tick",
    "nominal_angles",
    "nominal_positions",
    "nominal_speed",
    "signed_turns",
    "snap_ended",
    "tick_fractions",
    "tracking_errors",
]

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
#: A quarter turn [rad]: a turning robot facing heading ``h`` (quarter turns clockwise
#: from east, rows growing southwards) has its body at the angle ``h QUARTER``.
QUARTER = math.pi / 2
#: The ``(d_row, d_col)`` of a forward move along each heading.
HEADING_STEPS = np.array(ACTION_DELTAS, dtype=np.int64)[HEADING_MOVES]
HEADING_STEPS.flags.writeable = False


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


# ---------------------------------------------------------------------- the drive
def drive_executor_tick(
    world: BatchedPhysicsWorld,
    executor: Any,
    left_before: np.ndarray,
    done_before: np.ndarray,
    faced: np.ndarray | None,
    ended: np.ndarray,
    tick_steps: int,
) -> np.ndarray:
    """Drive ``world``'s bodies through the tick ``executor`` (an
    :class:`~warehouse_phys.execution.executor.Executor`) just ran, from the cells left,
    the ticks done and the headings faced before it (cell indices, ``faced`` ``None`` for
    robots that do not turn) and the actions that ``ended`` in it; each robot's snap error
    [cells], 0 where no action ended."""
    cols = world.grid.cols
    before, after = tick_fractions(done_before, executor.done, ended, executor.ticks_needed)
    turns = {} if faced is None else {"headings_before": faced, "headings_after": executor.facing}
    _, snap = world.drive_tick(
        np.stack(np.divmod(left_before, cols), axis=1),
        np.stack(np.divmod(executor.entered, cols), axis=1),
        before, after, ended, tick_steps, **turns,
    )  # fmt: skip
    errors = np.zeros(world.n_robots)
    errors[ended] = snap
    return errors


def aim_controls(world: BatchedPhysicsWorld, tick: Tick, entered_xy: np.ndarray) -> None:
    """Start a tick of ``world`` (:meth:`BatchedPhysicsWorld.drive_tick`): each control body
    on its robot's nominal position at ``tick.before``, with the velocity that carries it
    along the nominal segment to the tick's ``after`` (towards the centres ``entered_xy``
    [m] of the cells entered), and a turning robot's turning at a constant spin from its
    nominal angle at ``before`` to the one at ``after``; one batched read and write."""
    duration = tick.tick_steps * world.config.dt
    start, velocity = control_motion(
        world._centre_xy, entered_xy, tick.before, tick.after, duration
    )
    states, control = world._rows.states, world._rows.control_rows
    states.read(world.space)
    states.positions[control] = start
    states.velocities[control] = velocity
    if tick.turns is not None:
        angle, spin = control_turn(world.headings, tick.turns, tick.before, tick.after, duration)
        states.angles[control], states.spins[control] = angle, spin
    states.write(world.space)


def snap_ended(
    world: BatchedPhysicsWorld, tick: Tick, entered_xy: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """End a tick of ``world`` (:meth:`BatchedPhysicsWorld.drive_tick`, whose answer this
    is): read every body (and check it), snap the ended robots onto the centres
    ``entered_xy`` [m] of their cells ``tick.entered`` at rest (and turning ones onto their
    ``tick.headings_after``), and note their new cells (and headings)."""
    rows = world._rows
    states, robot_rows, ended = rows.states, rows.robot_rows, tick.ended
    states.read(world.space)
    cells_xy = world._lattice.cells_of(states.positions[robot_rows])
    if world.turning:
        check_angles(states.angles[robot_rows])
        world.read_headings, world.heading_errors = np.zeros(0, dtype=np.int64), np.zeros(0)
    if not ended.any():
        return np.zeros((0, 2), dtype=np.int64), np.zeros(0)
    centre_xy = entered_xy[ended]
    offset = states.positions[robot_rows[ended]] - centre_xy
    snap_error = np.sqrt(np.einsum("ij,ij->i", offset, offset)) / world._size
    body_rows = np.concatenate((robot_rows[ended], rows.control_rows[ended]))
    states.positions[body_rows] = np.concatenate((centre_xy, centre_xy))
    states.velocities[body_rows] = 0.0  # at rest: no velocity, no spin
    states.spins[body_rows] = 0.0
    if tick.headings_after is not None:
        _snap_headings(world, ended, tick.headings_after, body_rows)
    states.write(world.space)
    world.cells = world.cells.copy()
    world.cells[ended] = tick.entered[ended]
    world._centre_xy = world._centre_xy.copy()
    world._centre_xy[ended] = centre_xy
    return cells_xy[ended][:, ::-1], snap_error


def _snap_headings(
    world: BatchedPhysicsWorld, ended: np.ndarray, turned_to: np.ndarray, rows: np.ndarray
) -> None:
    """Read each ended turning robot's heading from its body's angle (in the states
    just read), note how far that angle is from the heading ``turned_to`` its action
    ends facing, and put the body and its control body (``rows``) on that heading."""
    states = world._rows.states
    angles = states.angles[world._rows.robot_rows[ended]]
    world.read_headings = np.rint(angles / QUARTER).astype(np.int64) % 4
    snapped = turned_to[ended] * QUARTER
    off = np.remainder(angles - snapped + math.pi, 2 * math.pi) - math.pi
    world.heading_errors = np.abs(off)
    states.angles[rows] = np.concatenate((snapped, snapped))
    world.headings = world.headings.copy()
    world.headings[ended] = turned_to[ended]


#: Names that moved to the modules above this one (they import it), still found here.
_MOVED = {
    "FRACTION_TOLERANCE": "tick_arguments",
    "Tick": "tick_arguments",
    "check_tick": "tick_arguments",
    "TickMotion": "tick_controller",
    "check_tick_controller": "tick_controller",
    "required_min_gap": "tick_controller",
}


def __getattr__(name: str) -> Any:
    if name in _MOVED:
        import importlib  # on demand: those modules import this one

        return getattr(importlib.import_module(f"warehouse_phys.physics.{_MOVED[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
