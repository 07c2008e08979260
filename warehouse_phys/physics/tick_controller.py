"""The tick controller check: how closely bodies follow their nominal positions tick by
tick, measured on probes, and the smallest ``min_gap`` the physics twin then accepts.

:mod:`~warehouse_phys.physics.ticking` derives what the executor's robots need from their
bodies: each body within ``e + TRACKING_MARGIN`` of its nominal position (its *tracking
error* ``e``), so that robots whose nominal positions stay ``min_gap`` apart never overlap
by more than the collision slop when ``min_gap >= d - s + 2 (e + TRACKING_MARGIN)``. This
module measures ``e`` and gives that bound:

- :func:`check_tick_controller` drives probe robots through ticks (a grid twin,
  :class:`~warehouse_phys.execution.async_grid.AsyncGrid`, beside a batched world: moves
  and stops of every kind, turning robots too), refuses a setting whose bodies stray,
  end on another cell or heading, or end too far off, and caches its answer, a
  :class:`TickMotion`;
- :func:`required_min_gap` is the clearance formula with that ``e``.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from warehouse_phys.execution.async_grid import AsyncGrid
from warehouse_phys.execution.ticks import check_ticks_per_move, check_whole
from warehouse_phys.physics.batched import BatchedPhysicsWorld
from warehouse_phys.physics.config import (
    HEADING_SNAP_BOUND,
    MAX_STEPS_PER_MOVE,
    SNAP_ERROR_BOUND,
    PhysicsConfig,
)
from warehouse_phys.physics.controller import probe_floor
from warehouse_phys.physics.engine import new_space
from warehouse_phys.physics.tick_arguments import _first, _pair
from warehouse_phys.physics.ticking import (
    HEADING_STEPS,
    TRACKING_MARGIN,
    angle_errors,
    default_tick_steps,
    nominal_speed,
    tick_fractions,
    tracking_errors,
)
from warehouse_phys.world.grid import ACTION_DELTAS
from warehouse_phys.world.headings import TurnAction, turned


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
        tick_steps: Physics steps in a tick (default
            :func:`~warehouse_phys.physics.ticking.default_tick_steps`).
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
    contact deeper than the collision slop: ``d - s + 2 (e + TRACKING_MARGIN)`` (derived in
    :mod:`~warehouse_phys.physics.ticking`), with ``e`` from :func:`check_tick_controller`
    (same arguments; for a fleet of turning robots ``turning=True``, whose ``e`` also
    counts centres during turns).

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
    plans = _plan_arrays(_probe_patterns(ticks), tuple(moves for _, moves in _PROBE_ROUTES))
    floor = probe_floor()
    moves, patterns, needed, cols = plans.actions, plans.patterns, plans.needed, floor.cols
    starts = np.array([_PROBE_ROUTES[r][0] for r in plans.route_of], dtype=np.int64)
    world = BatchedPhysicsWorld(floor, config, starts, record_path=True)
    twin = AsyncGrid(floor, starts[:, 0] * cols + starts[:, 1], needed)
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
    plans = _plan_arrays(_probe_patterns(ticks), tuple(route for *_, route in _TURN_ROUTES))
    actions, patterns, needed = plans.actions, plans.patterns, plans.needed
    cells = np.array([_TURN_ROUTES[r][0] for r in plans.route_of], dtype=np.int64)
    facing = np.array([_TURN_ROUTES[r][1] for r in plans.route_of], dtype=np.int64)
    world = BatchedPhysicsWorld(probe_floor(), config, cells, record_path=True, headings=facing)
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
