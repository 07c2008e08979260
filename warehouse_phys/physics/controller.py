"""The controller check: tries a configuration's moves on a small floor and refuses one
that could break a promise; measures how far the controller carries a robot past its
aims (:class:`ControllerMotion`, which the fleet's clearance rule needs). Also the
measures it uses on a recorded path: :func:`penetration` and :func:`speed_profile`.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from warehouse_phys.physics.config import (
    HEADING_SNAP_BOUND,
    PENETRATION_TOLERANCE,
    SNAP_ERROR_BOUND,
    PhysicsConfig,
)
from warehouse_phys.physics.world import PhysicsWorld
from warehouse_phys.world.grid import ACTION_DELTAS, Action, Cell, WarehouseGrid
from warehouse_phys.world.headings import HEADING_MOVES, TurnAction, turning_moves


def speed_profile(
    start: tuple[float, float], path: np.ndarray, config: PhysicsConfig
) -> tuple[np.ndarray, np.ndarray]:
    """The body's speed over one recorded move.

    Args:
        start: The ``(row, col)`` the move started from, in cell units (its
            cell, since every move starts snapped onto a centre).
        path: The move's positions after each physics step, ``(k, 2)`` in
            cell units, as in :attr:`PhysicsWorld.last_path`.
        config: The configuration the move ran with (its ``dt`` and ``cell_size``).

    Returns:
        The time at the end of each physics step since the move began [s], and
        the body's mean speed over that step [m/s]; both of shape ``(k,)``.
    """
    path = np.asarray(path, dtype=np.float64)
    if path.ndim != 2 or path.shape[1] != 2:
        raise ValueError(f"path must have shape (k, 2), got {path.shape}")
    points = np.concatenate([np.asarray(start, dtype=np.float64)[None, :], path])
    distances = np.linalg.norm(np.diff(points, axis=0), axis=1) * config.cell_size  # [m]
    times = config.dt * np.arange(1, len(path) + 1)
    return times, distances / config.dt


def penetration(grid: WarehouseGrid, radius: float, path: np.ndarray) -> np.ndarray:
    """How deep the robot's disc goes into a wall or a shelf at each point of ``path``.

    Args:
        grid: The floor (its size and its shelves).
        radius: The disc's radius [cells].
        path: Centres of the disc, ``(k, 2)`` of ``(row, col)`` in cell units
            (cell centres at whole numbers), as :attr:`PhysicsWorld.last_path`.

    Returns:
        ``(k,)`` depths [cells], 0 where the disc touches nothing. A disc whose
        centre is inside a wall or shelf counts at least its radius.
    """
    path = np.asarray(path, dtype=np.float64).reshape(-1, 2)
    row, col = path[:, 0], path[:, 1]
    # The floor spans -0.5 .. rows - 0.5 in cell units; walls lie beyond.
    depth = np.maximum.reduce(
        [
            radius - (row + 0.5),
            row + radius - (grid.rows - 0.5),
            radius - (col + 0.5),
            col + radius - (grid.cols - 0.5),
            np.zeros(len(path)),
        ]
    )
    for shelf_row, shelf_col in grid.shelves:
        # Distance from the centre to the shelf's square; depth = radius - distance.
        d_row = np.maximum(np.abs(row - shelf_row) - 0.5, 0.0)
        d_col = np.maximum(np.abs(col - shelf_col) - 0.5, 0.0)
        depth = np.maximum(depth, radius - np.hypot(d_row, d_col))
    return depth


@functools.cache
def probe_floor() -> WarehouseGrid:
    """The floor the controllers are tried on (:func:`check_controller` and the tick
    controller's check): room to overshoot in every direction, open cells beside the
    walls, and a shelf to bump into along both axes.

    Built on first use rather than at import: importing the package builds no floor.
    """
    return WarehouseGrid.from_layout([".....", ".....", "...#.", ".....", "....."])


#: (start, actions) of each probe; every move's cell is checked against the grid rules.
_PROBES: tuple[tuple[Cell, tuple[int, ...]], ...] = (
    *((Cell(2, 2), (action,)) for action in range(4)),  # free moves, nothing ahead for 2 cells
    (Cell(0, 3), (2,)),  # a free move that ends beside a wall
    (Cell(0, 0), (0,)),  # a bump into the left wall
    (Cell(0, 0), (3,)),  # a bump into the top wall
    (Cell(2, 2), (2,)),  # a bump into the shelf along a row...
    (Cell(1, 3), (1,)),  # ... and along a column
    # Moves after moves: reversals, turns, repeated bumps, a bump then away and back.
    (Cell(0, 0), (0, 2, 2, 0, 3, 3, 1, 1, 2, 2, 2, 1, 1, 0, 2, 3, 3, 2, 2, 1, 1, 1, 0, 3)),
)


class ControllerMotion(NamedTuple):
    """How far the controller's moves carry the robot beyond where they aim [cells],
    the largest of every move :func:`check_controller` tries.

    The fleet's traffic rule needs these to keep robots apart
    (:func:`~warehouse_phys.world.traffic.check_clearance`).
    """

    #: Past the centre of the cell a free move enters, along the move.
    overshoot: float
    #: Past the robot's own centre, away from the wall, when a bump drives it back.
    bump_overshoot: float
    #: Sideways, across the direction of any move.
    drift: float


def _motion(start: Cell, action: int, free: bool, path: np.ndarray) -> ControllerMotion:
    """The :class:`ControllerMotion` of one move from ``start`` along ``action``."""
    d_row, d_col = ACTION_DELTAS[action]
    offset = path - np.array(start, dtype=np.float64)
    along = offset @ np.array([d_row, d_col], dtype=np.float64)
    across = offset @ np.array([d_col, -d_row], dtype=np.float64)
    drift = float(np.abs(across).max(initial=0.0))
    if free:
        return ControllerMotion(max(float(along.max(initial=1.0)) - 1.0, 0.0), 0.0, drift)
    return ControllerMotion(0.0, max(float(-along.min(initial=0.0)), 0.0), drift)


#: (start, heading, actions) of each turning robot's probe: turns both ways and round,
#: forward moves after turns, a bump after a turn, turns beside a wall and a shelf.
_TURN_PROBES: tuple[tuple[Cell, int, tuple[int, ...]], ...] = (
    (Cell(2, 2), 0, (1, 1, 1, 1, 2, 2, 2, 2, 1, 0, 2, 2, 0, 0, 1, 1, 0, 3, 2, 0)),
    (Cell(0, 0), 0, (2, 0, 2, 0, 1, 1, 0, 0, 1, 2, 0, 3)),
    (Cell(2, 1), 0, (0, 1, 0, 2, 2, 0, 1, 0)),
)


@functools.cache
def check_controller(config: PhysicsConfig, *, turning: bool = False) -> ControllerMotion:
    """Refuse a configuration whose moves could break a promise of the environments;
    measure how far beyond its aims the controller carries the robot.

    Tries the controller on a small floor (see ``_PROBES``): free moves in every
    direction with open floor beyond (so no wall hides an overshoot), a free
    move that ends beside a wall, bumps into walls and into a shelf along both
    axes, and a long chain of such moves (so that what one move leaves in the
    solver carries into the next). Every move must end on the cell the grid
    rules give, less than half of :data:`SNAP_ERROR_BOUND` from its centre (the
    other half is a margin for floors and histories not tried here), and the
    disc must never go deeper than :data:`PENETRATION_TOLERANCE` into a wall or
    shelf. The environments call this when they are built; the answer for a
    configuration is cached.

    With ``turning=True`` (a fleet of turning robots) it also tries turning robots
    (see ``_TURN_PROBES``): quarter turns both ways, full rounds, forward moves and a
    bump after turns, turns beside walls and a shelf. Each must end on the cell and
    heading the rules give, the angle within half of :data:`HEADING_SNAP_BOUND` of the
    heading; a turning robot's centre must stay put, and how far it moves counts as
    sideways drift.

    Returns:
        The largest overshoots and sideways drift of the moves tried
        (:class:`ControllerMotion`), which the physics fleet checks against
        the room its traffic rule leaves between robots.

    Raises:
        ValueError: saying which move failed and how, with advice.
    """
    advice = "raise max_force, max_speed or gain, or lengthen move_duration"
    radius = config.robot_radius / config.cell_size
    overshoot = bump_overshoot = drift = 0.0
    floor = probe_floor()
    for start, actions in _PROBES:
        world = PhysicsWorld(floor, config, start, record_path=True)
        cell = start
        for action in actions:
            expected = floor.move(cell, action)
            kind = "a free move" if expected != cell else "a bump into a wall or shelf"
            name = f"{kind} from {tuple(cell)} ({Action(action).name})"
            try:
                result = world.move(action)
            except RuntimeError as error:
                raise ValueError(f"with these settings {name} fails: {error}; {advice}") from None
            path = world.last_path
            depth = float(penetration(floor, radius, path).max())
            if depth > PENETRATION_TOLERANCE:
                raise ValueError(
                    f"with these settings {name} drives the robot {depth:.3g} cells into a "
                    f"wall or shelf, more than the tolerance of {PENETRATION_TOLERANCE}; "
                    "lower max_force or max_speed, or raise robot_mass"
                )
            if result.cell != expected:
                raise ValueError(
                    f"with these settings {name} ends on {tuple(result.cell)}, "
                    f"not {tuple(expected)}: the controller cannot bring the robot there; {advice}"
                )
            if not result.snap_error < SNAP_ERROR_BOUND / 2:
                raise ValueError(
                    f"with these settings {name} ends {result.snap_error:.3g} cells from the "
                    f"centre, not within half the bound of {SNAP_ERROR_BOUND}; {advice}"
                )
            motion = _motion(cell, action, expected != cell, path)
            overshoot = max(overshoot, motion.overshoot)
            bump_overshoot = max(bump_overshoot, motion.bump_overshoot)
            drift = max(drift, motion.drift)
            cell = expected
    found = ControllerMotion(overshoot, bump_overshoot, drift)
    if turning:
        found = ControllerMotion(
            *(float(x) + 0.0 for x in np.maximum(found, _turning_motion(config, advice)))
        )
    return found


def _turning_motion(config: PhysicsConfig, advice: str) -> ControllerMotion:
    """The :class:`ControllerMotion` of the turning robot's probes, or the ``ValueError``
    of the first move that breaks a promise."""
    from warehouse_phys.physics.batched import BatchedPhysicsWorld

    radius = config.robot_radius / config.cell_size
    found = np.zeros(3)
    floor = probe_floor()
    cols = floor.cols
    for start, heading, actions in _TURN_PROBES:
        world = BatchedPhysicsWorld(floor, config, [start], record_path=True,
                                    headings=[heading])  # fmt: skip
        here, facing = np.array([start.row * cols + start.col]), np.array([heading])
        for action in actions:
            grants = turning_moves(floor, here, facing, np.array([action]), None)
            name = f"{TurnAction(action).name} from {divmod(int(here[0]), cols)} facing {facing[0]}"
            ends = np.stack(np.divmod(grants.ends, cols), axis=1)
            try:
                cells, headings, snap = world.move_turning(ends, grants.headings, grants.bumped)
            except RuntimeError as error:
                raise ValueError(f"with these settings {name} fails: {error}; {advice}") from None
            path = world.last_paths[0]
            depth = float(penetration(floor, radius, path).max())
            wrong = (cells != ends).any() or headings[0] != grants.headings[0]
            if wrong or depth > PENETRATION_TOLERANCE or not snap[0] < SNAP_ERROR_BOUND / 2:
                raise ValueError(
                    f"with these settings a turning robot's {name} ends on "
                    f"{tuple(cells[0].tolist())} facing {headings[0]} (the rules: "
                    f"{tuple(ends[0].tolist())} facing {grants.headings[0]}), "
                    f"{snap[0]:.3g} cells from the centre, {depth:.3g} cells into a wall; {advice}"
                )
            if not world.heading_errors[0] < HEADING_SNAP_BOUND / 2:
                raise ValueError(
                    f"with these settings a turning robot's {name} ends "
                    f"{world.heading_errors[0]:.3g} rad off its heading, not within half the "
                    f"bound of {HEADING_SNAP_BOUND}; {advice}"
                )
            origin = divmod(int(here[0]), cols)
            if action == TurnAction.FORWARD:
                move = int(HEADING_MOVES[facing[0]])
                motion = _motion(Cell(*origin), move, bool(grants.ends[0] != here[0]), path)
            else:  # a turn or a wait: the centre should not move; any motion is drift
                motion = ControllerMotion(0.0, 0.0, float(np.abs(path - origin).max()))
            found = np.maximum(found, motion)
            here, facing = grants.ends, grants.headings
    return ControllerMotion(*found.tolist())
