"""Many robots in one pymunk space, all moved at once: the batched physics world.

:class:`BatchedPhysicsWorld` is the engine of :class:`~warehouse_phys.physics.PhysicsWorld`
for many robots: the same space settings, walls, shelves, robot body and
controller (built by the same functions of :mod:`warehouse_phys.physics.engine`), the
same two move phases and the same snap, with every robot advanced by one space
step per physics step. Each robot stands on a *floor*, a copy of the grid's
walls and shelves: robots on different floors are far apart and never meet
(one floor each is the vector environment); robots on the same floor are
bodies that can touch (a fleet).

Positions go in and out through pymunk's batched I/O (:mod:`pymunk.batch`),
one call for every body of the space, never through per-body properties.

It also drives asynchronous execution a tick at a time (:meth:`BatchedPhysicsWorld.drive_tick`:
each body follows its nominal position between cells, a turning body its nominal angle
too; the geometry and the drive are :mod:`~warehouse_phys.physics.ticking`'s). The
lock-step moves are :mod:`~warehouse_phys.physics.lockstep`'s, the floors' lattice (floor
0 exactly where the single world has its floor) :mod:`~warehouse_phys.physics.floor_lattice`'s.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from warehouse_phys.physics.body_io import BodyRows
from warehouse_phys.physics.config import PhysicsConfig
from warehouse_phys.physics.engine import (
    CAN_RESTART,
    RobotBodies,
    add_robot,
)
from warehouse_phys.physics.floor_lattice import (
    FLOOR_GAP,
    GAP_REACH,
    FloorLattice,
    checked_floors,
)
from warehouse_phys.physics.lockstep import (
    ACTION_DELTA_ARRAY,
    granted_aims,
    move_bodies,
    turning_aims,
)
from warehouse_phys.physics.regions import RegionRows, check_threads
from warehouse_phys.physics.safety import SafetyRecord
from warehouse_phys.physics.tick_arguments import check_tick, checked_headings
from warehouse_phys.physics.ticking import QUARTER, aim_controls, nominal_positions, snap_ended
from warehouse_phys.world.grid import WarehouseGrid

__all__ = ["ACTION_DELTA_ARRAY", "FLOOR_GAP", "GAP_REACH", "BatchedPhysicsWorld"]


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
        threads: How many spaces the robots' bodies are held in, each a band of the floor
            stepped on a thread of its own (:mod:`~warehouse_phys.physics.regions`): 1
            (default) one space; for more, bodies that may touch during a move share a
            space, and the bodies move bit for bit as in one space while none touch.
        safety: Whether every move and tick is measured (:attr:`safety`, a
            :class:`~warehouse_phys.physics.safety.SafetyRecord`: closest approach and
            contacts deeper than the collision slop); it records the paths.

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
        threads: int = 1,
        safety: bool = False,
    ) -> None:
        starts = np.array(starts, dtype=np.int64).reshape(-1, 2)
        n_robots = len(starts)
        if n_robots == 0:
            raise ValueError("a batched world needs at least one robot")
        floor_of, n_floors = checked_floors(floor_of, n_robots)
        self.grid = grid
        self.config = config
        self.threads = check_threads(threads)
        self.record_path = bool(record_path or safety)
        self.n_robots = n_robots
        self.n_floors = n_floors
        #: ``(N,)`` int64: the floor each robot stands on.
        self.floor_of = floor_of
        self._size = size = config.cell_size
        self._lattice = lattice = FloorLattice(grid, size, floor_of, n_floors)
        lattice.check_cells(starts, "start")
        lattice.check_one_per_cell(starts, "start")
        #: Whether the robots turn (built with ``headings``).
        self.turning = headings is not None
        #: ``(N,)`` int64: each turning robot's heading after the last move (zeros if
        #: the robots do not turn).
        self.headings = checked_headings(headings, n_robots)
        self._drive_steps = config.steps_per_move - config.settle_steps
        self._settle_steps = config.settle_steps
        #: ``(floors, 2)`` float64: each floor's top-left corner ``(x, y)`` [m].
        self.floor_origins = lattice.origins

        self.cells = starts.copy()
        self._centre_xy = lattice.centres(starts)
        angles = (self.headings * QUARTER).tolist() if self.turning else [None] * n_robots
        self._rows: BodyRows | RegionRows
        if self.threads > 1:  # bands of the floor, a space each
            self._rows = RegionRows(lattice, config, self._centre_xy,
                                    angles if self.turning else None, self.threads)  # fmt: skip
            self.space, self.spaces, self.bodies = None, self._rows.spaces, self._rows.bodies
        else:
            self.space = lattice.new_space(config)
            self.bodies: list[RobotBodies] = [
                add_robot(self.space, config, tuple(xy), angle)
                for xy, angle in zip(self._centre_xy.tolist(), angles, strict=True)
            ]
            self._rows = BodyRows(self.space, self.bodies, angles=self.turning, config=config)
            self.spaces = [self.space]
        #: The closest approach and the contacts deeper than the slop, measured at every
        #: physics step since the world was built or restarted whole (``safety=True``).
        self.safety = SafetyRecord(n_robots, grid, config) if safety else None
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
        if self.threads == 1:
            state.pop("_rows")
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        if self.threads == 1:  # new C objects
            self._rows = BodyRows(self.space, self.bodies, angles=self.turning, config=self.config)
        else:
            self.spaces, self.bodies = self._rows.spaces, self._rows.bodies

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
        return move_bodies(self, aims, turns)

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
        return self.move(granted_aims(self.cells, actions, ends, bumped))

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
        aims, turns = turning_aims(self.cells, self.headings, ends, headings, bumped)
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
                (:func:`~warehouse_phys.physics.tick_arguments.check_tick`).
            RuntimeError: if a body's position or angle is not finite or it left the
                floor.
        """
        tick = check_tick(self, left, entered, before, after, ended, tick_steps,
                          headings_before, headings_after)  # fmt: skip
        entered_xy = self._lattice.centres(tick.entered)
        if self.threads > 1:  # bodies that may touch in this tick share a space
            self._rows.regroup(nominal_positions(self.cells, tick.entered, tick.before),
                               nominal_positions(self.cells, tick.entered, tick.after),
                               self.floor_of)  # fmt: skip
        aim_controls(self, tick, entered_xy)
        self._move_starts = self.cells
        self._advance(tick.tick_steps, 0, tick.tick_steps, read=False)
        self._measure()
        self.fractions = np.where(tick.ended, 0.0, tick.after)
        self.entering = tick.entered
        if tick.headings_after is not None:
            self.turning_to = tick.headings_after
        return snap_ended(self, tick, entered_xy)

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
        self._lattice.check_cells(starts, "start")
        cells = self.cells.copy()
        cells[robots] = starts
        if self.n_floors < self.n_robots:  # robots share floors: one per cell
            self._lattice.check_one_per_cell(cells, "start")
        centre_xy = self._lattice.centres(starts, robots)
        if self.turning:
            turned = checked_headings(headings, len(robots))
            self.headings, self.turning_to = self.headings.copy(), self.turning_to.copy()
            self.headings[robots] = self.turning_to[robots] = turned
        angles = (
            (self.headings[robots] * QUARTER).tolist() if self.turning else [None] * len(robots)
        )
        for robot, xy, angle in zip(robots.tolist(), centre_xy.tolist(), angles, strict=True):
            self._rows.renew(robot, xy, angle)
        everyone = len(robots) == self.n_robots and (np.sort(robots) == np.arange(len(robots)))
        if CAN_RESTART and np.all(everyone):
            # Every robot anew: the space's next step is a first. (Without pymunk's
            # internals it keeps its last step; with every joint and contact new, there
            # is no impulse for it to warm-start anyway.)
            self._rows.clear_time_step()
        if np.all(everyone) and self.safety is not None:
            self.safety.clear()
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
        return self._lattice.to_cells(self._rows.robot_xy())

    def orientations(self) -> np.ndarray:
        """Every turning robot's angle now, ``(N,)`` in quarter turns clockwise from east
        (whole numbers are headings; between them while it turns)."""
        if not self.turning:
            raise RuntimeError("these robots do not turn; build the world with headings")
        return self._rows.robot_angles() / QUARTER

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
        return self._lattice.to_cells(self._path).transpose(1, 0, 2).copy()

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
        return self._lattice.closest_approach(self._path, self._move_starts, reach)

    # ------------------------------------------------------------------ helpers
    def _advance(
        self, steps: int, first: int, length: int | None = None, *, read: bool = True
    ) -> np.ndarray | None:
        """Run ``steps`` physics steps (the move's steps ``first``, ``first + 1``, ..., of
        ``length`` steps in all, default ``steps_per_move``); the robots' ``(x, y)`` [m]
        after the last (``read=False``: ``None``, unless the path is recorded)."""
        dt, rows = self.config.dt, self._rows
        if not self.record_path:
            rows.advance(steps, dt)
            return rows.robot_xy() if read else None
        if first == 0:
            length = self.config.steps_per_move if length is None else length
            self._path = np.empty((length, self.n_robots, 2))
            if self.turning:
                self._turn_path = np.empty((length, self.n_robots))
        turn_path = self._turn_path if self.turning else None
        rows.record(dt, range(first, first + steps), self._path, turn_path)
        return self._path[first + steps - 1].copy()

    def _measure(self) -> None:
        """Measure the last move's or tick's physics steps into :attr:`safety`."""
        if self.safety is not None:
            self.safety.observe(self._path, self._lattice.origin, self._size, self.floor_of,
                                self._rows.region)  # fmt: skip

    def on_free_cells(self, cells: np.ndarray) -> np.ndarray:
        """``(k,)`` whether each of ``cells`` (``(k, 2)`` integers ``(row, col)``) is a
        cell a robot may stand on."""
        return self._lattice.on_free_cell(np.asarray(cells)[:, ::-1])
