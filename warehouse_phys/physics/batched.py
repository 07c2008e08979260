"""Many robots in one pymunk space, all moved at once: the batched physics world.

:class:`BatchedPhysicsWorld` is the engine of :class:`~warehouse_phys.physics.PhysicsWorld`
for many robots: the same space settings, walls, shelves, robot body and
controller (built by the same functions of :mod:`warehouse_phys.physics`), the
same two move phases and the same snap, with every robot advanced by one space
step per physics step. Each robot stands on a *floor*, a copy of the grid's
walls and shelves: robots on different floors are far apart and never meet
(one floor each is the vector environment); robots on the same floor are
bodies that can touch (a fleet).

Positions go in and out through pymunk's batched I/O (:mod:`pymunk.batch`),
one call for every body of the space, never through per-body properties.

It also drives asynchronous execution a tick at a time (:meth:`BatchedPhysicsWorld.drive_tick`:
each body follows its nominal position between cells, a turning body its nominal angle
too; the geometry, the checks and the clearance formula are
:mod:`~warehouse_phys.physics.ticking`'s).

Floors are laid out on a square lattice, floor 0 with its top-left corner at
the origin, exactly where the single world has its floor. Chipmunk solves
each robot's joint and contacts with only that robot's bodies and the static
walls (which no impulse moves), so a robot on floor 0 follows the single world
bit for bit. On another floor every coordinate carries the floor's offset, so
positions are rounded to the offset's precision (about ``1e-16`` times the
offset) and a robot there follows the single world to within about ``1e-12``
of a cell, not bit for bit; the tests bound it by ``1e-9``.

Its length is one class, the batched world, whose moves must match the single
world's step for step (docstrings give the geometry that proof rests on).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pymunk
import pymunk.batch
from scipy.spatial import cKDTree

from warehouse_phys.physics import (
    CAN_RESTART,
    POSITION_FIELD,
    WALL_THICKNESS,
    PhysicsConfig,
    PositionReader,
    RobotBodies,
    add_floor,
    add_robot,
    clear_time_step,
    new_space,
    renew_robot,
    space_stepping,
)
from warehouse_phys.physics.ticking import (
    QUARTER,
    BodyStates,
    Tick,
    check_tick,
    control_motion,
    control_turn,
)
from warehouse_phys.world.grid import ACTION_DELTAS, WarehouseGrid

#: Empty floor between the walls of two neighbouring floors [cells].
FLOOR_GAP = 1.0

#: Farthest apart two robots' cells may be at the start of a move, counted in steps
#: along rows and columns, for their discs to touch during it [cells]. A centre moves
#: along one axis, at most 1 + e cells, and drifts sideways at most s, where the fleet's
#: clearance check keeps e and s below (1 - d) / 2 for discs of diameter d < 1; so two
#: centres' row-and-column distance changes by at most 4 - 2d, and discs that touch
#: are less than sqrt(2) d apart that way: they started less than 4 apart.
GAP_REACH = 3

#: ``ACTION_DELTAS`` as an array: ``ACTION_DELTA_ARRAY[action]`` is ``(d_row, d_col)``.
ACTION_DELTA_ARRAY = np.array(ACTION_DELTAS, dtype=np.int64)
#: The aims of a fleet's actions: the four moves, then a wait (no change).
_AIM_DELTAS = np.concatenate([ACTION_DELTA_ARRAY, np.zeros((1, 2), dtype=np.int64)])

_POSITION = POSITION_FIELD
_SNAP_FIELDS = (
    pymunk.batch.BodyFields.POSITION
    | pymunk.batch.BodyFields.VELOCITY
    | pymunk.batch.BodyFields.ANGULAR_VELOCITY
)
#: Turning robots: the angle too (the buffers hold x, y, angle, vx, vy, spin a body).
_POSE = POSITION_FIELD | pymunk.batch.BodyFields.ANGLE
_TURNING_SNAP_FIELDS = _SNAP_FIELDS | pymunk.batch.BodyFields.ANGLE
#: How the heading (quarter turns clockwise from east) moves a forward move's aim.
_HEADING_DELTAS = np.array([(0, 1), (1, 0), (0, -1), (-1, 0)], dtype=np.int64)
_BODY_ID = pymunk.batch.BodyFields.BODY_ID


class BatchedPhysicsWorld:
    """Robots on copies of one floor, in one pymunk space, each moved by its controller.

    A move (:meth:`move`) runs the single world's phases for every robot at
    once: each control body goes to the centre of the robot's *aim* (a
    neighbouring cell, beyond a wall if one is there, or the robot's own cell
    to hold it there); after the drive steps each control body moves to the
    centre nearest to its robot; after the settle steps every cell is read
    from its body, the distance to that cell's centre is the snap error, and
    the body is snapped onto the centre at rest.

    Args:
        grid: The floor every robot stands on (each on its own copy, or on a shared one).
        config: The physical parameters (checked by the caller with
            :func:`~warehouse_phys.physics.check_controller`).
        starts: ``(N, 2)`` integers: the ``(row, col)`` each robot starts on, at rest.
        floor_of: ``(N,)`` integers: the floor each robot stands on, floors
            numbered from 0 with none left out. Default: each robot on its own floor.
        record_path: Whether :meth:`move` records every body's position after
            each physics step (see :attr:`last_paths`).
        headings: ``(N,)`` integers 0..3, for turning robots: each robot's heading
            (quarter turns clockwise from east, rows growing southwards). Each body
            then faces its heading and a gear joint turns it
            (:func:`~warehouse_phys.physics.engine.add_robot`); :meth:`move_turning`
            (lock step) and :meth:`drive_tick` (tick by tick) drive the turns, and the
            heading is read from the body's angle and snapped like its position.
            ``None`` (default): robots that do not turn.

    Raises:
        ValueError: if a start is off the floor or on a shelf, two robots on
            one floor start on the same cell, or the arrays have the wrong shape.
    """

    def __init__(
        self,
        grid: WarehouseGrid,
        config: PhysicsConfig,
        starts: np.ndarray | Sequence[Sequence[int]],
        floor_of: np.ndarray | Sequence[int] | None = None,
        *,
        record_path: bool = False,
        headings: np.ndarray | Sequence[int] | None = None,
    ) -> None:
        starts = np.array(starts, dtype=np.int64).reshape(-1, 2)
        n_robots = len(starts)
        if n_robots == 0:
            raise ValueError("a batched world needs at least one robot")
        floor_of, n_floors = _checked_floors(floor_of, n_robots)
        self.grid = grid
        self.config = config
        self.record_path = record_path
        self.n_robots = n_robots
        self.n_floors = n_floors
        #: ``(N,)`` int64: the floor each robot stands on.
        self.floor_of = floor_of
        self._free_padded = _padded_free_cells(grid)
        self._padded_strides = np.array([1, grid.cols + 2], dtype=np.int64)  # (col, row)
        self._clip_high = np.array([grid.cols, grid.rows], dtype=np.int64)
        self._check_cells(starts, "start")
        self._check_one_per_cell(starts, "start")
        #: Whether the robots turn (built with ``headings``).
        self.turning = headings is not None
        #: ``(N,)`` int64: each turning robot's heading after the last move (zeros if
        #: the robots do not turn).
        self.headings = self._checked_headings(headings, n_robots)

        self._size = size = config.cell_size
        self._drive_steps = config.steps_per_move - config.settle_steps
        self._settle_steps = config.settle_steps

        #: ``(floors, 2)`` float64: each floor's top-left corner ``(x, y)`` [m].
        self.floor_origins = _floor_origins(grid, size, n_floors)
        self._origin = self.floor_origins[floor_of]  # (N, 2) [m], each robot's floor

        self.space = new_space(config)
        for origin in self.floor_origins.tolist():
            add_floor(self.space, grid, size, tuple(origin))
        self.bodies: list[RobotBodies] = []
        self.cells = starts.copy()
        self._centre_xy = self._centres(starts)
        angles = (self.headings * QUARTER).tolist() if self.turning else [None] * n_robots
        for xy, angle in zip(self._centre_xy.tolist(), angles, strict=True):
            self.bodies.append(add_robot(self.space, config, tuple(xy), angle))

        self._body_ids = self._collect_body_ids()
        # Batched I/O: arrays with a row for every body of the space, in the space's order.
        self._positions_io = pymunk.batch.Buffer()
        self._snap_io = pymunk.batch.Buffer()
        self._pose_io = pymunk.batch.Buffer()
        self._find_bodies()
        self._path, self._turn_path = np.zeros((0, n_robots, 2)), np.zeros((0, n_robots))
        self._move_starts = self.cells
        #: Each robot's angle before its snap in the last move, off its heading [rad]
        #: (after a tick, :meth:`drive_tick`: each ended robot's, ``(k,)`` in robot order,
        #: off the heading its action ends facing).
        self.heading_errors = np.zeros(n_robots)
        #: After the last tick (:meth:`drive_tick`): ``(N,)`` the fraction of each robot's
        #: move done (0 at rest), ``(N, 2)`` the cell it enters (its own cell at rest).
        self.fractions, self.entering = np.zeros(n_robots), starts.copy()
        #: Turning robots, after the last tick: ``(N,)`` the heading each robot's action
        #: ends facing (its heading at rest), and ``(k,)`` int64 the heading read from
        #: each ended robot's angle before its snap (the nearest quarter turn).
        self.turning_to, self.read_headings = self.headings.copy(), np.zeros(0, dtype=np.int64)

    def __getstate__(self) -> dict[str, object]:
        # The batched I/O buffers hold C pointers; a copy or an unpickled world makes its own.
        state = self.__dict__.copy()
        for name in ("_reader", "_positions_io", "_snap_io", "_positions", "_snap", "_body_ids",
                     "_pose_io", "_pose", "_states"):  # fmt: skip
            state.pop(name)
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._positions_io = pymunk.batch.Buffer()
        self._snap_io = pymunk.batch.Buffer()
        self._pose_io = pymunk.batch.Buffer()
        self._body_ids = self._collect_body_ids()  # a copy's bodies are new C objects
        self._find_bodies()

    # ------------------------------------------------------------------ moves
    def move(
        self, aims: np.ndarray, turns: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Drive every robot towards the centre of its aim, then snap it.

        Args:
            aims: ``(N, 2)`` integers: the cell each robot is driven to, a
                neighbour of its cell (beyond a wall or in a shelf, if one is
                there) or its own cell.
            turns: turning robots only: ``(N,)`` quarter turns each robot makes
                (-1 counter-clockwise, 0, 1 clockwise). Its control body takes the
                new angle for the whole move; at the end the heading is read from
                the body's angle (the nearest quarter turn, also :attr:`headings`;
                the angle's distance from it is :attr:`heading_errors`) and the body
                is snapped onto it with its position.

        Returns:
            The cell each body ended in (``(N, 2)`` int64, read from its
            position, also :attr:`cells`) and its distance from that cell's
            centre before the snap (``(N,)`` float64) [cells].

        Raises:
            RuntimeError: if a body's position is not finite or it left the
                floor, which a supported configuration never allows, or a robot is
                in mid-move (:meth:`drive_tick`).
        """
        if self.fractions.any():
            robot = int(np.flatnonzero(self.fractions)[0])
            raise RuntimeError(f"robot {robot} is in mid-move: finish its move with drive_tick")
        size, origin = self._size, self._origin
        self._move_starts = self.cells
        aims_xy = aims[:, ::-1]  # (col, row): the order of (x, y)
        aim_xy = (aims_xy + 0.5) * size + origin
        if self.turning:
            turns = np.zeros(self.n_robots, dtype=np.int64) if turns is None else turns
            self._write_poses(aim_xy, (self.headings + turns) * QUARTER)
        else:
            self._write_positions(self._centre_xy, aim_xy)
        xy = self._advance(self._drive_steps, 0)
        settle_on = np.floor((xy - origin) / size).astype(np.int64)
        off_aim = (settle_on != aims_xy).any(axis=1)
        if off_aim.any():  # walls stopped these bodies: drive back to the centre each is nearest
            aim_xy[off_aim] = (settle_on[off_aim] + 0.5) * size + origin[off_aim]
            self._write_positions(xy, aim_xy)
        xy = self._advance(self._settle_steps, self._drive_steps)

        cells_xy = self._cells_of(xy)
        centre_xy = (cells_xy + 0.5) * size + origin
        offset = xy - centre_xy
        snap_error = np.sqrt(np.einsum("ij,ij->i", offset, offset)) / size
        # The one teleport: every body onto its centre, at rest, with its aim on it too
        # (the snap array's velocities are always zero).
        self._snap[self._body_rows, :2] = np.concatenate((centre_xy, centre_xy))
        if self.turning:  # and onto its heading, its aim's angle too
            self._snap_headings()
            pymunk.batch.set_space_bodies(self.space, _TURNING_SNAP_FIELDS, self._snap_io)
        else:
            pymunk.batch.set_space_bodies(self.space, _SNAP_FIELDS, self._snap_io)
        self.cells = cells = cells_xy[:, ::-1]
        self._centre_xy = centre_xy
        return cells, snap_error

    def move_by(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`move` with each robot aimed one cell in the direction of its action (0..3)."""
        return self.move(self.cells + ACTION_DELTA_ARRAY[actions])

    def move_granted(
        self, actions: np.ndarray, ends: np.ndarray, bumped: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`move` for a fleet's joint step, as its traffic rule granted it.

        Args:
            actions: ``(N,)`` the robots' actions, 0..3 a move, 4 a wait.
            ends: ``(N, 2)`` the cell each robot ends on under the rule.
            bumped: ``(N,)`` whether the floor refused the robot's move.

        A robot whose cell changes drives to its end; a robot bumped by a wall or
        shelf drives towards it and back, as a single robot does; every other
        robot (waiting, or refused by traffic) holds its cell's centre.
        """
        cells = self.cells
        aims = cells + _AIM_DELTAS[actions]
        hold = ~((ends != cells).any(axis=1) | bumped)
        aims[hold] = cells[hold]
        return self.move(aims)

    def move_turning(
        self, ends: np.ndarray, headings: np.ndarray, bumped: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`move` for a joint step of turning robots, as the traffic rule granted it
        (:func:`~warehouse_phys.world.headings.turning_moves`).

        Args:
            ends: ``(N, 2)`` the cell each robot ends on under the rule.
            headings: ``(N,)`` each robot's heading after the step.
            bumped: ``(N,)`` whether the floor refused the robot's forward move.

        A robot whose cell changes drives there; a robot whose forward move the floor
        refused drives towards the wall or shelf ahead and back; a robot whose heading
        changes turns a quarter in place; every other robot holds its pose.

        Returns:
            The cell each body ended on, the heading read from each body (both as
            the rule's, the tests prove) and the snap error [cells].
        """
        aims = np.array(ends, dtype=np.int64).reshape(-1, 2)
        aims[bumped] = self.cells[bumped] + _HEADING_DELTAS[self.headings[bumped]]
        change = (np.asarray(headings, dtype=np.int64) - self.headings) % 4
        turns = np.where(change == 3, -1, change)
        cells, snap_error = self.move(aims, turns)
        return cells, self.headings.copy(), snap_error

    def drive_tick(
        self,
        left: np.ndarray,
        entered: np.ndarray,
        before: np.ndarray,
        after: np.ndarray,
        ended: np.ndarray,
        tick_steps: int,
        *,
        headings_before: np.ndarray | None = None,
        headings_after: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Run one tick of asynchronous execution: every body follows its robot's nominal
        position between cells, and a turning body its nominal angle
        (:mod:`~warehouse_phys.physics.ticking`).

        Args:
            left: ``(N, 2)`` integers: the cell each robot is on or leaves, ``(row, col)``
                (its :attr:`cells`).
            entered: ``(N, 2)`` integers: the cell each robot's move enters (a free
                neighbour; :attr:`entering` for a robot in mid-move), its own cell for a
                robot with no move or a turn; a turning robot's move goes straight ahead.
            before, after: ``(N,)`` real numbers, ``0 <= before <= after <= 1``: the
                fraction of each robot's move (or turn) done before and after the tick
                (:func:`~warehouse_phys.physics.ticking.tick_fractions`); ``before`` is
                where the last tick left it (:attr:`fractions`); a robot told STOP or
                delayed has ``after == before``; a robot with no action has both 0.
            ended: ``(N,)`` bools: the actions that end with this tick, exactly those
                with ``after == 1``.
            tick_steps: Physics steps in the tick, a whole number from 1.
            headings_before, headings_after: turning robots only, and required for them:
                ``(N,)`` integers 0..3, the heading each robot faces at the start of its
                current action (its :attr:`headings`) and at its end (the same for a
                forward move or none, a quarter turn either way for a turn in place;
                :attr:`turning_to` for a robot in mid-action).

        Each control body runs linearly along its robot's nominal segment over the
        ``tick_steps`` steps, and a turning robot's control body turns linearly from the
        nominal angle at ``before`` to the one at ``after`` (``headings_before`` plus the
        fraction of the signed quarter turn; the gear joint turns the body after it,
        the pivot joint holds its centre on the cell's centre). Then each ended robot's
        cell is read from its body and the body is snapped onto the centre of
        ``entered``, at rest, and a turning body onto the angle of ``headings_after``
        (the heading read from its angle is :attr:`read_headings`, its distance from
        that angle :attr:`heading_errors`). :attr:`cells`, :attr:`headings`,
        :attr:`fractions`, :attr:`entering` and :attr:`turning_to` say where each robot
        is. Costs one batched read and write of every body at each end of the tick, the
        steps, and O(N) array operations. With ``record_path``, :attr:`last_paths`,
        :attr:`last_orientations` and :meth:`closest_approach` cover the tick's steps.

        Returns:
            The cells the ended robots' bodies were on before the snap (``(k, 2)`` int64
            ``(row, col)``, in robot order, ``k = ended.sum()``) and their distances from
            the centres of their ``entered`` cells [cells] (``(k,)`` float64).

        Raises:
            TypeError, ValueError: one line naming the argument
                (:func:`~warehouse_phys.physics.ticking.check_tick`).
            RuntimeError: if a body's position or angle is not finite or it left the
                floor.
        """
        tick = check_tick(self, left, entered, before, after, ended, tick_steps,
                          headings_before, headings_after)  # fmt: skip
        entered_xy = self._centres(tick.entered)
        duration = tick.tick_steps * self.config.dt
        start, velocity = control_motion(
            self._centre_xy, entered_xy, tick.before, tick.after, duration
        )
        states, control = self._states, self._control_rows
        states.read(self.space)
        states.positions[control] = start
        states.velocities[control] = velocity
        if tick.turns is not None:
            angle, spin = control_turn(self.headings, tick.turns, tick.before, tick.after, duration)
            states.angles[control], states.spins[control] = angle, spin
        states.write(self.space)
        self._move_starts = self.cells
        if self.record_path:
            self._advance(tick.tick_steps, 0, tick.tick_steps)
        else:
            step, handle = space_stepping(self.space)
            for _ in range(tick.tick_steps):
                step(handle, self.config.dt)
        self.fractions = np.where(tick.ended, 0.0, tick.after)
        self.entering = tick.entered
        if tick.headings_after is not None:
            self.turning_to = tick.headings_after
        return self._snap_ended(tick, entered_xy)

    def _snap_ended(self, tick: Tick, entered_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`drive_tick`'s end: read every body (and check it), snap the ended robots
        onto the centres ``entered_xy`` [m] of their cells ``tick.entered`` at rest (and
        turning ones onto their ``tick.headings_after``)."""
        states, robot_rows, ended = self._states, self._robot_rows, tick.ended
        states.read(self.space)
        cells_xy = self._cells_of(states.positions[robot_rows])
        if self.turning:
            self._check_angles(states.angles[robot_rows])
            self.read_headings, self.heading_errors = np.zeros(0, dtype=np.int64), np.zeros(0)
        if not ended.any():
            return np.zeros((0, 2), dtype=np.int64), np.zeros(0)
        centre_xy = entered_xy[ended]
        offset = states.positions[robot_rows[ended]] - centre_xy
        snap_error = np.sqrt(np.einsum("ij,ij->i", offset, offset)) / self._size
        rows = np.concatenate((robot_rows[ended], self._control_rows[ended]))
        states.positions[rows] = np.concatenate((centre_xy, centre_xy))
        states.velocities[rows] = 0.0  # at rest: no velocity, no spin
        states.spins[rows] = 0.0
        if tick.headings_after is not None:
            self._snap_tick_headings(ended, tick.headings_after, rows)
        states.write(self.space)
        self.cells = self.cells.copy()
        self.cells[ended] = tick.entered[ended]
        self._centre_xy = self._centre_xy.copy()
        self._centre_xy[ended] = centre_xy
        return cells_xy[ended][:, ::-1], snap_error

    def _snap_tick_headings(
        self, ended: np.ndarray, turned_to: np.ndarray, rows: np.ndarray
    ) -> None:
        """Read each ended turning robot's heading from its body's angle (in the states
        just read), note how far that angle is from the heading ``turned_to`` its action
        ends facing, and put the body and its control body (``rows``) on that heading."""
        angles = self._states.angles[self._robot_rows[ended]]
        self.read_headings = np.rint(angles / QUARTER).astype(np.int64) % 4
        snapped = turned_to[ended] * QUARTER
        off = np.remainder(angles - snapped + math.pi, 2 * math.pi) - math.pi
        self.heading_errors = np.abs(off)
        self._states.angles[rows] = np.concatenate((snapped, snapped))
        self.headings = self.headings.copy()
        self.headings[ended] = turned_to[ended]

    @staticmethod
    def _check_angles(angles: np.ndarray) -> None:
        """Raise a ``RuntimeError`` if a robot's angle [rad] is not finite."""
        if not np.isfinite(angles).all():
            robot = int(np.flatnonzero(~np.isfinite(angles))[0])
            raise RuntimeError(f"robot {robot}'s angle became {angles[robot]!r}")

    def closest_gaps(self) -> np.ndarray:
        """Each robot's smallest gap to another's disc during the last move [cells]:
        :meth:`closest_approach` less the robots' diameter (negative: they overlapped)."""
        return self.closest_approach() - self.config.robot_diameter

    def restart(
        self,
        robots: np.ndarray | Sequence[int],
        starts: np.ndarray,
        headings: np.ndarray | Sequence[int] | None = None,
    ) -> None:
        """Make the given robots as newly built, at rest on ``starts`` (``(k, 2)``),
        turning robots facing ``headings`` (``(k,)``, default east).

        Each robot's disc leaves the space with its cached contacts and comes
        back, its body gets a new body's state and a new joint replaces the old
        (see :func:`~warehouse_phys.physics.renew_robot`): what happens next
        depends on nothing that came before, and the other robots go on
        undisturbed. A new joint and new contacts start from zero impulse, so
        the space's warm start gives them none: the robot moves exactly as in a
        new world (the tests replay it bit for bit after random histories). When
        every robot restarts, the space also forgets its last time step, as a
        new space has none: a restarted world is a new one, without building
        anything (a reset of a fleet or of a vector env costs no allocation and
        leaks no native memory). The bodies keep their places in the space, so
        the batched arrays keep their order.
        """
        robots = np.array(robots, dtype=np.int64).reshape(-1)
        starts = np.array(starts, dtype=np.int64).reshape(-1, 2)
        if len(robots) != len(starts):
            raise ValueError(f"{len(robots)} robots but {len(starts)} starts")
        if len(robots) == 0:
            return
        self._check_cells(starts, "start")
        cells = self.cells.copy()
        cells[robots] = starts
        if self.n_floors < self.n_robots:  # robots share floors: one per cell
            self._check_one_per_cell(cells, "start")
        centre_xy = self._centres(starts, robots)
        if self.turning:
            turned = self._checked_headings(headings, len(robots))
            self.headings, self.turning_to = self.headings.copy(), self.turning_to.copy()
            self.headings[robots] = self.turning_to[robots] = turned
        angles = (
            (self.headings[robots] * QUARTER).tolist() if self.turning else [None] * len(robots)
        )
        for robot, xy, angle in zip(robots.tolist(), centre_xy.tolist(), angles, strict=True):
            self.bodies[robot] = renew_robot(self.space, self.config, self.bodies[robot], xy, angle)
        everyone = len(robots) == self.n_robots and (np.sort(robots) == np.arange(len(robots)))
        if CAN_RESTART and np.all(everyone):
            # Every robot anew: the space's next step is a first. (Without pymunk's
            # internals it keeps its last step; with every joint and contact new, there
            # is no impulse for it to warm-start anyway.)
            clear_time_step(self.space)
        self.cells = cells
        self.fractions = self.fractions.copy()
        self.fractions[robots] = 0.0
        self.entering = cells.copy()
        self._move_starts = self._move_starts.copy()
        self._move_starts[robots] = starts
        self._centre_xy = self._centre_xy.copy()
        self._centre_xy[robots] = centre_xy
        if self.record_path and len(self._path):
            self._path[:, robots] = centre_xy
            if self.turning:
                self._turn_path[:, robots] = self.headings[robots] * QUARTER

    # ------------------------------------------------------------------ reading
    def positions(self) -> np.ndarray:
        """Every robot's position now, ``(N, 2)`` of ``(row, col)`` in cell units on its floor."""
        return self._to_cells(self._read_robots())

    def orientations(self) -> np.ndarray:
        """Every turning robot's angle now, ``(N,)`` in quarter turns clockwise from east
        (whole numbers are headings; between them while it turns)."""
        if not self.turning:
            raise RuntimeError("these robots do not turn; build the world with headings")
        return self._reader.read(self.space)[self._robot_rows, 2] / QUARTER

    @property
    def last_orientations(self) -> np.ndarray:
        """Every turning robot's angle after each physics step of the last move (or tick,
        of :meth:`drive_tick`), before the snap: ``(N, steps_per_move)`` quarter turns
        (``(N, tick_steps)`` after a tick; see :meth:`orientations`).

        Raises:
            RuntimeError: if the world does not record paths or the robots do not turn.
        """
        if not (self.record_path and self.turning):
            raise RuntimeError("only a world of turning robots that records paths has them")
        return (self._turn_path / QUARTER).T.copy()

    @property
    def last_paths(self) -> np.ndarray:
        """Every robot's position after each physics step of the last move (or tick, of
        :meth:`drive_tick`), before the snap.

        A fresh float64 array of shape ``(N, steps_per_move, 2)`` (``(N, tick_steps, 2)``
        after a tick) of ``(row, col)``
        in cell units on the robot's floor (cell centres at whole numbers), as
        :attr:`~warehouse_phys.physics.PhysicsWorld.last_path` for each robot;
        ``(N, 0, 2)`` before the first move. A robot restarted since holds its
        start throughout.

        Raises:
            RuntimeError: if the world does not record paths.
        """
        if not self.record_path:
            raise RuntimeError("this world does not record paths; build it with record_path=True")
        return self._to_cells(self._path).transpose(1, 0, 2).copy()

    def closest_approach(self, reach: int = GAP_REACH) -> np.ndarray:
        """How close each robot's centre came to another's during the last move [cells].

        Compared, at every physics step of the move: the robots on the same floor
        whose cells at its start were at most ``reach`` steps apart along rows and
        columns (a k-d tree finds them). Robots farther apart cannot touch when the
        fleet's clearance check holds (:data:`GAP_REACH`), so every approach that
        matters is measured, exactly; robots out of reach are not (their discs stay
        at least sqrt(2) (1 - e) - d cells apart, for diameter d and a controller that
        carries a robot e past its aims). O(N x steps) array operations.

        Returns:
            ``(N,)`` float64: each robot's smallest distance to a robot within reach,
            ``inf`` for a robot with none (and for every robot before the first move).

        Raises:
            RuntimeError: if the world does not record paths.
        """
        if not self.record_path:
            raise RuntimeError("this world does not record paths; build it with record_path=True")
        closest = np.full(self.n_robots, np.inf)
        if self.n_robots < 2 or not len(self._path):
            return closest
        starts = self._move_starts
        if self.n_floors > 1:  # each floor where it lies: more than 3 cells from the next
            starts = starts + self._origin[:, ::-1] / self._size
        pairs = cKDTree(starts).query_pairs(reach, p=1, output_type="ndarray")
        first, second = pairs[:, 0], pairs[:, 1]
        if self.n_floors > 1:
            same = self.floor_of[first] == self.floor_of[second]
            first, second = first[same], second[same]
        if len(first):
            # Robot by robot: each pair's two paths are two contiguous rows.
            path = self._to_cells(self._path).transpose(1, 0, 2).reshape(self.n_robots, -1)
            offset = path[first] - path[second]  # (pairs, steps * 2): row, col, row, ...
            offset *= offset
            apart = np.sqrt((offset[:, 0::2] + offset[:, 1::2]).min(axis=1))
            np.minimum.at(closest, first, apart)
            np.minimum.at(closest, second, apart)
        return closest

    # ------------------------------------------------------------------ helpers
    def _advance(self, steps: int, first: int, length: int | None = None) -> np.ndarray:
        """Run ``steps`` physics steps (the move's steps ``first``, ``first + 1``, ..., of
        ``length`` steps in all, default ``steps_per_move``); the robots' ``(x, y)`` [m]
        after the last."""
        step, handle = space_stepping(self.space)
        dt = self.config.dt
        if not self.record_path:
            for _ in range(steps):
                step(handle, dt)
            return self._read_robots()
        if first == 0:
            length = self.config.steps_per_move if length is None else length
            self._path = np.empty((length, self.n_robots, 2))
        path, read, space, rows = self._path, self._reader.read, self.space, self._robot_rows
        if self.turning:
            if first == 0:
                self._turn_path = np.empty((len(path), self.n_robots))
            turn_path = self._turn_path
            for index in range(first, first + steps):
                step(handle, dt)
                pose = read(space)[rows]
                path[index], turn_path[index] = pose[:, :2], pose[:, 2]
            return path[first + steps - 1].copy()
        for index in range(first, first + steps):
            step(handle, dt)
            read(space).take(rows, axis=0, out=path[index])  # the robots' rows, in place
        return path[first + steps - 1].copy()

    def _read_robots(self) -> np.ndarray:
        """Every robot's ``(x, y)`` [m], in robot order, with one batched read."""
        return self._reader.read(self.space)[self._robot_rows, :2]  # fancy indexing: a copy

    def _write_poses(self, control_xy: np.ndarray, control_angles: np.ndarray) -> None:
        """Turning robots: place every control body and turn it to ``control_angles``
        [rad], with one batched write; every robot is written as it stands, at rest on
        its centre and heading (a move starts from the last snap)."""
        pose = self._pose
        pose[self._robot_rows, :2] = self._centre_xy
        pose[self._robot_rows, 2] = self.headings * QUARTER
        pose[self._control_rows, :2] = control_xy
        pose[self._control_rows, 2] = control_angles
        pymunk.batch.set_space_bodies(self.space, _POSE, self._pose_io)

    def _snap_headings(self) -> None:
        """Read each turning robot's heading from its body's angle (the nearest quarter
        turn), note how far it was off, and put both the body and its control body on it
        in the snap array."""
        angles = self._reader.read(self.space)[self._robot_rows, 2]
        self._check_angles(angles)
        quarters = np.rint(angles / QUARTER)
        self.heading_errors = np.abs(angles - quarters * QUARTER)
        self.headings = quarters.astype(np.int64) % 4
        snapped = self.headings * QUARTER
        self._snap[self._body_rows, 2] = np.concatenate((snapped, snapped))

    @staticmethod
    def _checked_headings(headings: object, n: int) -> np.ndarray:
        """``headings`` as ``(n,)`` int64 in 0..3 (zeros for ``None``), or a ``ValueError``."""
        if headings is None:
            return np.zeros(n, dtype=np.int64)
        array = np.asarray(headings)
        if array.shape != (n,) or array.dtype.kind not in "iu" or ((array < 0) | (array > 3)).any():
            raise ValueError(f"headings must be {n} integers 0..3, got {headings!r}")
        return array.astype(np.int64)

    def _write_positions(self, robot_xy: np.ndarray, control_xy: np.ndarray) -> None:
        """Place every robot and every control body [m], with one batched write.

        A robot is written where it is (``robot_xy`` as read or as snapped),
        which chipmunk stores unchanged: only the control bodies move.
        """
        self._positions[self._robot_rows] = robot_xy
        self._positions[self._control_rows] = control_xy
        pymunk.batch.set_space_bodies(self.space, _POSITION, self._positions_io)

    def _collect_body_ids(self) -> np.ndarray:
        """The ids of every robot's body, then of every control body, in robot order."""
        return np.array(
            [b.robot.id for b in self.bodies] + [b.control.id for b in self.bodies],
            dtype=np.uintp,
        )

    def _find_bodies(self) -> None:
        """Find where each robot's and each control body's data sit in the batched arrays.

        The order is the space's (read back by body id when the world is built
        or copied; bodies never leave, so it never changes). The walls' static
        body is in it too: a write gives it back its own position, at rest.
        """
        buffer = pymunk.batch.Buffer()
        pymunk.batch.get_space_bodies(self.space, _BODY_ID | _POSITION, buffer)
        in_space = np.frombuffer(buffer.int_buf(), dtype=np.uintp)
        every_xy = np.frombuffer(buffer.float_buf(), dtype=np.float64).reshape(-1, 2)
        ours = self._body_ids
        by_id = np.argsort(ours)
        slot = np.searchsorted(ours[by_id], in_space).clip(max=len(ours) - 1)
        known = ours[by_id][slot] == in_space
        if known.sum() != len(ours):  # pragma: no cover - a body of ours is missing
            raise RuntimeError("the space lost a robot's body")
        where = np.empty(len(ours), dtype=np.int64)  # our index -> row in the space's order
        where[by_id[slot[known]]] = np.flatnonzero(known)
        self._robot_rows = where[: self.n_robots]
        self._control_rows = where[self.n_robots :]
        self._body_rows = where  # robots, then their control bodies
        self._positions = every_xy.copy()  # the rows of other bodies keep their positions
        self._positions_io.set_float_buf(self._positions)
        self._reader = PositionReader(len(in_space), angles=self.turning)
        # x, y, (angle,) vx, vy, angular velocity: the snap's velocities are zero
        self._snap = np.zeros((len(in_space), 6 if self.turning else 5))
        self._snap[:, :2] = every_xy
        self._snap_io.set_float_buf(self._snap)
        self._pose = np.zeros((len(in_space), 3))  # x, y, angle
        if self.turning:
            pose_buffer = pymunk.batch.Buffer()
            pymunk.batch.get_space_bodies(self.space, _POSE, pose_buffer)
            self._pose[:] = np.frombuffer(pose_buffer.float_buf(), dtype=np.float64).reshape(-1, 3)
            self._snap[:, 2] = self._pose[:, 2]
        self._pose_io.set_float_buf(self._pose)
        self._states = BodyStates(len(in_space), angles=self.turning)

    def _centres(self, cells: np.ndarray, robots: np.ndarray | None = None) -> np.ndarray:
        """The centres ``(x, y)`` [m] of ``cells`` (``(k, 2)`` row, col) on the floors of
        ``robots`` (default: every robot, in order)."""
        origin = self._origin if robots is None else self._origin[robots]
        return (cells[:, ::-1] + 0.5) * self._size + origin

    def _to_cells(self, xy: np.ndarray) -> np.ndarray:
        """``(..., N, 2)`` positions ``(x, y)`` [m] as ``(row, col)`` in cells on each floor."""
        return ((xy - self._origin) / self._size - 0.5)[..., ::-1]

    def on_free_cells(self, cells: np.ndarray) -> np.ndarray:
        """``(k,)`` whether each of ``cells`` (``(k, 2)`` integers ``(row, col)``) is a
        cell a robot may stand on."""
        return self._on_free_cell(np.asarray(cells)[:, ::-1])

    def _cells_of(self, xy: np.ndarray) -> np.ndarray:
        """The ``(col, row)`` of the cell each robot's ``(x, y)`` [m] lies in (the centre
        nearest to it).

        Raises:
            RuntimeError: if a position is not finite or off the floor or on a shelf.
        """
        local = xy - self._origin
        if not np.isfinite(local).all():
            robot = int(np.flatnonzero(~np.isfinite(local).all(axis=1))[0])
            raise RuntimeError(f"robot {robot}'s position became {tuple(xy[robot].tolist())}")
        cells_xy = np.floor(local / self._size).astype(np.int64)
        lost = ~self._on_free_cell(cells_xy)
        if lost.any():
            robot = int(np.flatnonzero(lost)[0])
            x, y = local[robot].tolist()
            raise RuntimeError(
                f"robot {robot} left the floor or entered a shelf: it is at ({x:.3f}, {y:.3f}) m"
            )
        return cells_xy

    def _on_free_cell(self, cells_xy: np.ndarray) -> np.ndarray:
        """Whether each ``(col, row)`` is a cell a robot may stand on."""
        # _free_padded has a border of False around the floor: clip anything beyond onto it.
        padded = np.minimum(np.maximum(cells_xy, -1), self._clip_high) + 1  # (np.clip is slower)
        return self._free_padded[padded @ self._padded_strides]

    def _check_cells(self, cells: np.ndarray, name: str) -> None:
        bad = ~self._on_free_cell(cells[:, ::-1])
        if bad.any():
            robot = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"robot {robot}'s {name} {tuple(cells[robot].tolist())} is off the "
                f"{self.grid.rows}x{self.grid.cols} floor, on a shelf or out of reach"
            )

    def _check_one_per_cell(self, cells: np.ndarray, name: str) -> None:
        keys = self.floor_of * (self.grid.rows * self.grid.cols) + (
            cells[:, 0] * self.grid.cols + cells[:, 1]
        )
        unique, counts = np.unique(keys, return_counts=True)
        if (counts > 1).any():
            shared = unique[counts > 1][0]
            robots = np.flatnonzero(keys == shared).tolist()
            raise ValueError(f"robots {robots} {name} on the same cell of the same floor")


def _checked_floors(
    floor_of: np.ndarray | Sequence[int] | None, n_robots: int
) -> tuple[np.ndarray, int]:
    """Each robot's floor as ``(N,)`` int64 (default: one floor each), and the number of
    floors; a ``ValueError`` unless they are numbered 0, 1, ... with none left out."""
    floor_of = (
        np.arange(n_robots, dtype=np.int64)
        if floor_of is None
        else np.array(floor_of, dtype=np.int64).reshape(-1)
    )
    if floor_of.shape != (n_robots,):
        raise ValueError(
            f"floor_of must have one floor per robot ({n_robots}), got shape {floor_of.shape}"
        )
    n_floors = int(floor_of.max()) + 1
    if floor_of.min() < 0 or len(np.unique(floor_of)) != n_floors:
        raise ValueError("floors must be numbered 0, 1, ... with none left out")
    return floor_of, n_floors


def _padded_free_cells(grid: WarehouseGrid) -> np.ndarray:
    """Whether a robot may stand on each cell, flat, with a border of False all round:
    ``(rows + 2) * (cols + 2)`` bools, cell ``(row, col)`` at ``(row + 1) (cols + 2) + col + 1``."""
    free = np.zeros((grid.rows + 2) * (grid.cols + 2), dtype=bool)
    for row, col in grid.reachable:
        free[(row + 1) * (grid.cols + 2) + col + 1] = True
    return free


def _floor_origins(grid: WarehouseGrid, size: float, n_floors: int) -> np.ndarray:
    """The floors' top-left corners ``(x, y)`` [m], ``(floors, 2)``: a square lattice,
    floor 0 at the origin, :data:`FLOOR_GAP` between the walls of neighbours."""
    side = math.ceil(math.sqrt(n_floors))
    pitch_x = (grid.cols + 2 * WALL_THICKNESS + FLOOR_GAP) * size
    pitch_y = (grid.rows + 2 * WALL_THICKNESS + FLOOR_GAP) * size
    floors = np.arange(n_floors)
    return np.stack([floors % side * pitch_x, floors // side * pitch_y], axis=1)
