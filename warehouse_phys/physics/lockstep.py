"""The batched world's lock-step moves: every robot driven to its aim at once, then snapped.

:meth:`~warehouse_phys.physics.batched.BatchedPhysicsWorld.move` runs the single world's
two phases for every robot (:func:`move_bodies`): each control body goes to the centre of
its robot's *aim*, a robot that a wall stopped is driven back to the centre it is nearest,
and after the settle steps every body is read and snapped onto its cell's centre (a
turning robot onto the nearest heading too). :func:`granted_aims` and
:func:`turning_aims` turn a fleet's step, as its traffic rule granted it, into aims
(``move_granted``, ``move_turning``). These functions read and set the world's state:
they are its methods' bodies, kept here with the geometry they share.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from warehouse_phys.physics.body_io import check_angles
from warehouse_phys.physics.ticking import QUARTER
from warehouse_phys.world.grid import ACTION_DELTAS

if TYPE_CHECKING:
    from warehouse_phys.physics.batched import BatchedPhysicsWorld

#: ``ACTION_DELTAS`` as an array: ``ACTION_DELTA_ARRAY[action]`` is ``(d_row, d_col)``.
ACTION_DELTA_ARRAY = np.array(ACTION_DELTAS, dtype=np.int64)
#: The aims of a fleet's actions: the four moves, then a wait (no change).
_AIM_DELTAS = np.concatenate([ACTION_DELTA_ARRAY, np.zeros((1, 2), dtype=np.int64)])
#: How the heading (quarter turns clockwise from east) moves a forward move's aim.
_HEADING_DELTAS = np.array([(0, 1), (1, 0), (0, -1), (-1, 0)], dtype=np.int64)


def move_bodies(
    world: BatchedPhysicsWorld, aims: np.ndarray, turns: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`BatchedPhysicsWorld.move` (which see): drive every robot towards its aim's
    centre, back to the nearest centre where a wall stopped it, settle, read and snap;
    the cells and the snap errors [cells]."""
    if world.fractions.any():
        robot = int(np.flatnonzero(world.fractions)[0])
        raise RuntimeError(f"robot {robot} is in mid-move: finish its move with drive_tick")
    if world.threads > 1:  # bodies that may touch in this move share a space
        world._rows.regroup(world.cells.astype(np.float64), aims.astype(np.float64),
                            world.floor_of)  # fmt: skip
    size, origin, rows = world._size, world._lattice.origin, world._rows
    world._move_starts = world.cells
    aims_xy = aims[:, ::-1]  # (col, row): the order of (x, y)
    aim_xy = (aims_xy + 0.5) * size + origin
    if world.turning:  # every robot written as it stands: on its centre and heading
        turns = np.zeros(world.n_robots, dtype=np.int64) if turns is None else turns
        angles = world.headings * QUARTER
        rows.write_poses(world._centre_xy, angles, aim_xy, (world.headings + turns) * QUARTER)
    else:
        rows.write_positions(world._centre_xy, aim_xy)
    xy = world._advance(world._drive_steps, 0)
    settle_on = np.floor((xy - origin) / size).astype(np.int64)
    off_aim = (settle_on != aims_xy).any(axis=1)
    if off_aim.any():  # walls stopped these bodies: drive back to the centre each is nearest
        aim_xy[off_aim] = (settle_on[off_aim] + 0.5) * size + origin[off_aim]
        rows.write_positions(xy, aim_xy)
    xy = world._advance(world._settle_steps, world._drive_steps)
    world._measure()

    cells_xy = world._lattice.cells_of(xy)
    centre_xy = (cells_xy + 0.5) * size + origin
    offset = xy - centre_xy
    snap_error = np.sqrt(np.einsum("ij,ij->i", offset, offset)) / size
    # The one teleport: every body onto its centre, at rest, with its aim on it too (and
    # onto its heading, its aim's angle too).
    rows.snap(centre_xy, _snap_headings(world) if world.turning else None)
    world.cells = cells = cells_xy[:, ::-1]
    world._centre_xy = centre_xy
    return cells, snap_error


def _snap_headings(world: BatchedPhysicsWorld) -> np.ndarray:
    """Read each turning robot's heading from its body's angle (the nearest quarter
    turn), note how far it was off, and return the angle to snap it (and its control
    body) onto [rad]."""
    angles = world._rows.robot_angles()
    check_angles(angles)
    quarters = np.rint(angles / QUARTER)
    world.heading_errors = np.abs(angles - quarters * QUARTER)
    world.headings = quarters.astype(np.int64) % 4
    return world.headings * QUARTER


def granted_aims(
    cells: np.ndarray, actions: np.ndarray, ends: np.ndarray, bumped: np.ndarray
) -> np.ndarray:
    """The aims of a fleet's joint step (:meth:`BatchedPhysicsWorld.move_granted`): a
    robot whose cell changes drives to its end, a robot bumped by a wall or shelf towards
    it (and back), every other robot holds its cell."""
    aims = cells + _AIM_DELTAS[actions]
    hold = ~((ends != cells).any(axis=1) | bumped)
    aims[hold] = cells[hold]
    return aims


def turning_aims(
    cells: np.ndarray,
    facing: np.ndarray,
    ends: np.ndarray,
    headings: np.ndarray,
    bumped: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The aims and signed quarter turns of a joint step of turning robots
    (:meth:`BatchedPhysicsWorld.move_turning`), from their cells and the headings they
    face: a bumped robot aims at the cell ahead, every other robot at its end."""
    aims = np.array(ends, dtype=np.int64).reshape(-1, 2)
    aims[bumped] = cells[bumped] + _HEADING_DELTAS[facing[bumped]]
    change = (np.asarray(headings, dtype=np.int64) - facing) % 4
    return aims, np.where(change == 3, -1, change)
