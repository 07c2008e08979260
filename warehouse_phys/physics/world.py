"""The pymunk world: floor, walls, robot body, move controller and the fixed physics clock.

The robot is a dynamic circle with real mass and moment on a top-down floor
(no gravity; the floor's drag is the space's damping) bounded by static walls.
It is never teleported during a move: a kinematic *control body* is placed on
the centre the robot should reach, and a pivot joint between the two pulls the
robot there with a capped force and a capped speed (pymunk's recommended way to
drive a body; see its ``tank.py`` example). The joint is the controller; its
gains are :class:`PhysicsConfig` fields, and the loop that runs a move does no
per-step Python work beyond stepping the space (and recording the body's
position, when asked).

One move is a fixed number of steps of a constant ``dt`` in two phases:

1. **drive**: the control body sits on the centre of the next cell in the
   direction of the action, even when that cell is beyond a wall;
2. **settle**: the control body moves to the centre nearest to where the body
   actually is, and the robot comes to rest there. After a free move this is
   the next cell (the aim does not change). After a move into a wall, which
   stopped the body, it is the robot's own cell: the robot visibly bumps into
   the wall and drives back.

At the end of the move the cell is read from the body's position (the nearest
centre), the distance to that centre is reported as the *snap error*, and only
then is the body snapped onto the centre with zero velocity.

Coordinates: ``x = (col + 0.5) * cell_size``, ``y = (row + 0.5) * cell_size``
in metres, so ``y`` grows downwards like the row index. Paths are reported in
*cell units* ``(row, col)`` with cell centres at whole numbers, which is what
the renderer takes.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from warehouse_phys.physics.config import PhysicsConfig
from warehouse_phys.physics.engine import (
    RobotBodies,
    add_floor,
    add_robot,
    clear_time_step,
    get_position,
    new_space,
    place_at_rest,
    renew_robot,
    set_position,
    space_stepping,
)
from warehouse_phys.world.grid import ACTION_DELTAS, Cell, WarehouseGrid


class MoveResult(NamedTuple):
    """How a move ended: the cell read from the body, and how far it was from its centre."""

    cell: Cell
    #: Distance between the body and ``cell``'s centre just before the snap [cells].
    snap_error: float


class PhysicsWorld:
    """A pymunk space with the floor's walls, the robot body and its controller.

    Each episode starts on a robot as newly built (a new world, or
    :meth:`restart`), so no contact cache or solver state carries over from one
    episode to the next and a seed replays bit for bit.

    Args:
        grid: the floor to build walls around.
        config: the physical parameters.
        start: the cell the robot starts on, at rest.
        record_path: whether :meth:`move` records the body's position after
            every physics step (see :attr:`last_path`). It makes a move about
            40 % slower, so training leaves it off.
    """

    def __init__(
        self,
        grid: WarehouseGrid,
        config: PhysicsConfig,
        start: tuple[int, int],
        *,
        record_path: bool = False,
    ) -> None:
        if not grid.is_free(start):
            raise ValueError(
                f"start {tuple(start)} is off the {grid.rows}x{grid.cols} floor or on a shelf"
            )
        self.grid = grid
        self.config = config
        self.record_path = record_path
        self._cell_size = config.cell_size
        self._dt = config.dt
        self._drive_steps = config.steps_per_move - config.settle_steps
        self._settle_steps = config.settle_steps
        self._path: list[tuple[float, float]] = []

        self.space = new_space(config)
        add_floor(self.space, grid, config.cell_size)
        self._add_robot(start)

    def restart(self, start: tuple[int, int]) -> None:
        """Begin a new episode: the robot as newly built, at rest on ``start``.

        The walls and shelves stay; everything that carries state from move to
        move is reset or new (see :func:`renew_robot`): the disc's cached
        contacts are dropped, the body has a new body's state, the new joint has
        no accumulated impulse, and the space's last time step is cleared, so
        that its first step applies no warm start: exactly what a new world's
        first step does. The tests check that an episode after many others
        replays bit for bit in a new world.
        """
        if not self.grid.is_free(start):
            raise ValueError(
                f"start {tuple(start)} is off the {self.grid.rows}x{self.grid.cols} floor "
                "or on a shelf"
            )
        bodies = RobotBodies(self.robot, self.robot_shape, self.control, self.joint)
        self.joint = renew_robot(self.space, self.config, bodies, self.centre(start)).joint
        clear_time_step(self.space)
        self._path.clear()
        self.cell = Cell(int(start[0]), int(start[1]))

    def _add_robot(self, start: tuple[int, int]) -> None:
        """Add the robot at rest on ``start``, and its controller, to the space."""
        bodies = add_robot(self.space, self.config, self.centre(start))
        self.robot, self.robot_shape, self.control, self.joint, _ = bodies
        self.cell = Cell(int(start[0]), int(start[1]))

    def centre(self, cell: tuple[int, int]) -> tuple[float, float]:
        """The centre of ``cell`` (on the floor or beyond it) as world ``(x, y)`` [m]."""
        size = self._cell_size
        return ((cell[1] + 0.5) * size, (cell[0] + 0.5) * size)

    def cell_at(self, x: float, y: float) -> Cell:
        """The cell whose centre is nearest to the point ``(x, y)`` [m] (the cell holding it)."""
        return Cell(math.floor(y / self._cell_size), math.floor(x / self._cell_size))

    def move(self, action: int) -> MoveResult:
        """Drive the robot one cell in the direction of ``action``, then snap it.

        Returns the cell the body ended in (read from its position) and the
        distance from the body to that cell's centre before the snap.

        Raises:
            RuntimeError: if the body's position is not finite or it left the
                floor, which a supported configuration never allows.
        """
        # Cells here are plain (row, col) tuples and centres are computed in place
        # (as centre() and cell_at() do): this is the hot path of every action.
        size, floor = self._cell_size, math.floor
        d_row, d_col = ACTION_DELTAS[action]
        aim = (self.cell[0] + d_row, self.cell[1] + d_col)  # beyond a wall, if one is there
        self._path.clear()
        step, space = self._stepping()
        set_position(self.control, ((aim[1] + 0.5) * size, (aim[0] + 0.5) * size))
        x, y = self._advance(step, space, self._drive_steps)
        settle_on = (floor(y / size), floor(x / size))
        if settle_on != aim:  # a wall stopped the body: drive back to the centre it is nearest
            set_position(self.control, ((settle_on[1] + 0.5) * size, (settle_on[0] + 0.5) * size))
        x, y = self._advance(step, space, self._settle_steps)

        if not (math.isfinite(x) and math.isfinite(y)):
            raise RuntimeError(f"the robot's position became {x!r}, {y!r}")
        cell = Cell(floor(y / size), floor(x / size))
        if not self.grid.is_free(cell):
            raise RuntimeError(
                f"the robot left the floor or entered a shelf: it is at ({x:.3f}, {y:.3f}) m"
            )
        centre = ((cell[1] + 0.5) * size, (cell[0] + 0.5) * size)
        snap_error = math.hypot(x - centre[0], y - centre[1]) / size
        # The one teleport: onto the centre, at rest, with the aim on it too.
        place_at_rest(self.robot, centre)
        if cell != settle_on:
            set_position(self.control, centre)
        self.cell = cell
        return MoveResult(cell, snap_error)

    def _advance(
        self, step: Callable[[Any, float], None], space: Any, steps: int
    ) -> tuple[float, float]:
        """Run ``steps`` physics steps with ``step(space, dt)`` (see :meth:`_stepping`),
        recording the path if asked; the body's final ``(x, y)``."""
        dt = self._dt
        if self.record_path:
            path, robot = self._path, self.robot
            for _ in range(steps):
                step(space, dt)
                path.append(get_position(robot))
            return path[-1]
        for _ in range(steps):
            step(space, dt)
        return get_position(self.robot)

    def _stepping(self) -> tuple[Callable[[Any, float], None], Any]:
        """The function that advances the space by one ``dt``, and what it takes first.

        chipmunk's ``cpSpaceStep`` on the space's C handle when pymunk exposes
        it, else ``pymunk.Space.step`` on the space. The handle is read from the
        space at each call and held only by the caller's frame while the world,
        hence its space, is alive: nothing outside the ``Space`` object keeps it,
        so the C space is freed with its ``Space`` and never from another
        object's finalizer (which chipmunk aborts on while a space is locked).
        Tests replace this method to look inside a move.
        """
        return space_stepping(self.space)

    @property
    def last_path(self) -> np.ndarray:
        """The body's positions after each physics step of the last move, before the snap.

        A float64 array of shape ``(steps_per_move, 2)`` holding ``(row, col)``
        in cell units (cell centres at whole numbers); a fresh copy. Empty
        before the first recorded move.

        Raises:
            RuntimeError: if the world does not record paths.
        """
        if not self.record_path:
            raise RuntimeError("this world does not record paths; build it with record_path=True")
        if not self._path:
            return np.empty((0, 2))
        xy = np.array(self._path, dtype=np.float64) / self._cell_size - 0.5
        return xy[:, ::-1].copy()
