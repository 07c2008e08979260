"""Every body of a space read or written with one batched call (:mod:`pymunk.batch`).

The batched world moves its robots' bodies in and out of pymunk through these, one call
for every body of the space, never through per-body properties:

- :class:`BodyRows`: where each robot's body and control body sit in the space's
  batched arrays, the buffers for a lock-step move (positions, poses, the snap), and
  each robot's pose recorded after every physics step;
- :class:`BodyStates`: every body's position, velocity and spin (and angle), read and
  written whole, for a tick (``BatchedPhysicsWorld.drive_tick``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pymunk
import pymunk.batch

from warehouse_phys.physics.config import PhysicsConfig
from warehouse_phys.physics.engine import (
    POSITION_FIELD,
    PositionReader,
    RobotBodies,
    clear_time_step,
    renew_robot,
    space_stepping,
)

#: Position, velocity and spin of a body in pymunk's batched I/O (5 numbers a body).
STATE_FIELDS = (
    pymunk.batch.BodyFields.POSITION
    | pymunk.batch.BodyFields.VELOCITY
    | pymunk.batch.BodyFields.ANGULAR_VELOCITY
)
#: The same with the angle, for turning robots (6 numbers a body: x, y, angle, vx, vy, spin).
TURNING_STATE_FIELDS = STATE_FIELDS | pymunk.batch.BodyFields.ANGLE

#: Position and angle (the buffers hold x, y, angle a body).
_POSE = POSITION_FIELD | pymunk.batch.BodyFields.ANGLE
_BODY_ID = pymunk.batch.BodyFields.BODY_ID


class BodyRows:
    """Where a world's robots and their control bodies sit in its space's batched arrays,
    and the buffers that read and write every body of the space with one call each.

    The order is the space's (read back by body id when the rows are built; bodies
    never leave, so it never changes). The walls' static body is in it too: a write
    gives it back its own position, at rest. The buffers hold C pointers: a copy or an
    unpickled world builds rows of its own (its bodies are new C objects).

    The same interface as :class:`~warehouse_phys.physics.regions.RegionRows` (the
    bodies held in several spaces): the batched world reads, writes, steps and renews its
    robots through either.

    Args:
        space: The world's space.
        bodies: Every robot's bodies, in robot order (the world's own list: a renewed
            robot's joint is put in it).
        angles: Whether the robots turn (their angles are read, written and snapped).
        config: The robots' physical parameters (to renew a robot).
    """

    #: The region of each robot: one space, no regions.
    region = None

    def __init__(
        self,
        space: pymunk.Space,
        bodies: list[RobotBodies],
        *,
        angles: bool,
        config: PhysicsConfig | None = None,
    ) -> None:
        self.space, self.bodies, self.config = space, bodies, config
        n_robots = len(bodies)
        ours = np.array(
            [b.robot.id for b in bodies] + [b.control.id for b in bodies], dtype=np.uintp
        )
        buffer = pymunk.batch.Buffer()
        pymunk.batch.get_space_bodies(space, _BODY_ID | POSITION_FIELD, buffer)
        in_space = np.frombuffer(buffer.int_buf(), dtype=np.uintp)
        every_xy = np.frombuffer(buffer.float_buf(), dtype=np.float64).reshape(-1, 2)
        by_id = np.argsort(ours)
        slot = np.searchsorted(ours[by_id], in_space).clip(max=len(ours) - 1)
        known = ours[by_id][slot] == in_space
        if known.sum() != len(ours):  # pragma: no cover - a body of ours is missing
            raise RuntimeError("the space lost a robot's body")
        where = np.empty(len(ours), dtype=np.int64)  # our index -> row in the space's order
        where[by_id[slot[known]]] = np.flatnonzero(known)
        #: Each robot's row, each control body's row, and both (robots first).
        self.robot_rows = where[:n_robots]
        self.control_rows = where[n_robots:]
        self.body_rows = where
        self._positions = every_xy.copy()  # the rows of other bodies keep their positions
        self._positions_io = pymunk.batch.Buffer()
        self._positions_io.set_float_buf(self._positions)
        #: Reads every body's position (and angle, for turning robots) in one call.
        self.reader = PositionReader(len(in_space), angles=angles)
        # x, y, (angle,) vx, vy, angular velocity: the snap's velocities are zero
        self._snap = np.zeros((len(in_space), 6 if angles else 5))
        self._snap[:, :2] = every_xy
        self._snap_io = pymunk.batch.Buffer()
        self._snap_io.set_float_buf(self._snap)
        self._snap_fields = TURNING_STATE_FIELDS if angles else STATE_FIELDS
        self._pose = np.zeros((len(in_space), 3))  # x, y, angle
        if angles:
            pose_buffer = pymunk.batch.Buffer()
            pymunk.batch.get_space_bodies(space, _POSE, pose_buffer)
            self._pose[:] = np.frombuffer(pose_buffer.float_buf(), dtype=np.float64).reshape(-1, 3)
            self._snap[:, 2] = self._pose[:, 2]
        self._pose_io = pymunk.batch.Buffer()
        self._pose_io.set_float_buf(self._pose)
        #: Every body's whole state, for a tick.
        self.states = BodyStates(len(in_space), angles=angles)

    def advance(self, steps: int, dt: float) -> None:
        """Run ``steps`` physics steps of ``dt`` [s]."""
        step, handle = space_stepping(self.space)
        for _ in range(steps):
            step(handle, dt)

    def record(
        self, dt: float, indices: range, path: np.ndarray, turn_path: np.ndarray | None = None
    ) -> None:
        """:meth:`record_steps` with the space's own step."""
        step, handle = space_stepping(self.space)
        self.record_steps(step, handle, dt, indices, path, turn_path)

    def renew(self, robot: int, xy: tuple[float, float], angle: float | None) -> None:
        """Make ``robot`` as newly built on ``xy`` [m] (facing ``angle``)
        (:func:`~warehouse_phys.physics.engine.renew_robot`)."""
        self.bodies[robot] = renew_robot(self.space, self.config, self.bodies[robot], xy, angle)

    def clear_time_step(self) -> None:
        """Forget the space's last time step (a world restarted whole)."""
        clear_time_step(self.space)

    def robot_xy(self) -> np.ndarray:
        """Every robot's ``(x, y)`` [m], in robot order, with one batched read."""
        return self.reader.read(self.space)[self.robot_rows, :2]  # fancy indexing: a copy

    def robot_angles(self) -> np.ndarray:
        """Every turning robot's angle [rad], in robot order, with one batched read."""
        return self.reader.read(self.space)[self.robot_rows, 2]

    def record_steps(
        self,
        step: Callable[[Any, float], None],
        handle: Any,
        dt: float,
        indices: range,
        path: np.ndarray,
        turn_path: np.ndarray | None = None,
    ) -> None:
        """Run a physics step ``step(handle, dt)`` (from
        :func:`~warehouse_phys.physics.engine.space_stepping`) for each of ``indices``, and
        after each read every robot's ``(x, y)`` [m] into ``path[index]`` (``(steps, N,
        2)``), and a turning robot's angle [rad] into ``turn_path[index]`` (``(steps, N)``)."""
        read, space, rows = self.reader.read, self.space, self.robot_rows
        if turn_path is not None:
            for index in indices:
                step(handle, dt)
                pose = read(space)[rows]
                path[index], turn_path[index] = pose[:, :2], pose[:, 2]
            return
        for index in indices:
            step(handle, dt)
            read(space).take(rows, axis=0, out=path[index])  # the robots' rows, in place

    def write_positions(self, robot_xy: np.ndarray, control_xy: np.ndarray) -> None:
        """Place every robot and every control body [m], with one batched write.

        A robot is written where it is (``robot_xy`` as read or as snapped),
        which chipmunk stores unchanged: only the control bodies move.
        """
        self._positions[self.robot_rows] = robot_xy
        self._positions[self.control_rows] = control_xy
        pymunk.batch.set_space_bodies(self.space, POSITION_FIELD, self._positions_io)

    def write_poses(
        self,
        robot_xy: np.ndarray,
        robot_angles: np.ndarray,
        control_xy: np.ndarray,
        control_angles: np.ndarray,
    ) -> None:
        """Turning robots: place every robot and control body [m] and turn it [rad], with
        one batched write (a robot written as it stands is stored unchanged)."""
        pose = self._pose
        pose[self.robot_rows, :2] = robot_xy
        pose[self.robot_rows, 2] = robot_angles
        pose[self.control_rows, :2] = control_xy
        pose[self.control_rows, 2] = control_angles
        pymunk.batch.set_space_bodies(self.space, _POSE, self._pose_io)

    def snap(self, centre_xy: np.ndarray, angles: np.ndarray | None = None) -> None:
        """The one teleport: every robot and its control body onto ``centre_xy`` [m] at
        rest (turning robots also onto ``angles`` [rad]), with one batched write (the
        snap array's velocities are always zero)."""
        self._snap[self.body_rows, :2] = np.concatenate((centre_xy, centre_xy))
        if angles is not None:
            self._snap[self.body_rows, 2] = np.concatenate((angles, angles))
        pymunk.batch.set_space_bodies(self.space, self._snap_fields, self._snap_io)


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


def check_angles(angles: np.ndarray) -> None:
    """Raise a ``RuntimeError`` if a robot's angle [rad] is not finite."""
    if not np.isfinite(angles).all():
        robot = int(np.flatnonzero(~np.isfinite(angles))[0])
        raise RuntimeError(f"robot {robot}'s angle became {angles[robot]!r}")
