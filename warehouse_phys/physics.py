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

import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import pymunk
import pymunk.batch

from warehouse_phys.grid import ACTION_DELTAS, Action, Cell, WarehouseGrid

#: Largest distance between the body and the centre it is snapped to at the end
#: of a move, in cells, that the environment promises for every move [cells].
SNAP_ERROR_BOUND = 0.02

#: Thickness of the static walls around the floor [cells]. A wall this thick
#: cannot be crossed in one physics step (steps are shorter than the robot's radius).
WALL_THICKNESS = 1.0

#: Overlap pymunk allows between touching shapes, to keep contacts steady [cells].
COLLISION_SLOP = 0.002

#: Friction coefficient of robot-wall contacts (rubber bumper on steel) [1].
WALL_FRICTION = 0.6

#: Deepest the robot's disc may go into a wall or a shelf at any physics step [cells]:
#: as far as the default robot travels in one step. Contacts are solved after the
#: overlap they resolve, so a bump always sinks in a little: the defaults reach 0.024,
#: a controller of 10,000 N about 0.1.
PENETRATION_TOLERANCE = 0.1

#: Most physics steps in one move: no setting may make an action cost more.
MAX_STEPS_PER_MOVE = 1000

#: The values each setting may take, (lowest, highest), in its unit. Outside them
#: the simulation loses precision or overflows; inside them the controller check
#: (:func:`check_controller`) decides whether a setting keeps every promise.
SUPPORTED_RANGES: dict[str, tuple[float, float]] = {
    "cell_size": (1e-3, 1e3),  # [m]
    "robot_radius": (1e-5, 5e2),  # [m], and less than half a cell
    "robot_mass": (1e-3, 1e6),  # [kg]
    "floor_damping": (1e-3, 1e3),  # [1/s]
    "max_speed": (1e-6, 1e6),  # [m/s], and less than robot_radius per step
    "max_force": (1e-6, 1e12),  # [N]
    "gain": (1e-3, 1e4),  # [1/s]
    "dt": (1e-5, 1.0),  # [s]
    "move_duration": (1e-5, 60.0),  # [s], and at most MAX_STEPS_PER_MOVE steps
    "settle_time": (1e-5, 60.0),  # [s], and shorter than a move
}


_UNITS = {
    "cell_size": "m",
    "robot_radius": "m",
    "robot_mass": "kg",
    "floor_damping": "1/s",
    "max_speed": "m/s",
    "max_force": "N",
    "gain": "1/s",
    "dt": "s",
    "move_duration": "s",
    "settle_time": "s",
}


@dataclass(frozen=True)
class PhysicsConfig:
    """The physical parameters of the robot, its controller and the physics clock.

    The defaults describe a 20 kg robot of 0.3 m radius on 1 m cells that
    crosses one cell in a quarter of a second: 15 steps of 1/60 s per move,
    one rendered frame per physics step at 60 fps.

    Every field is stored as a plain ``float``.

    Raises:
        TypeError: if a field is not a real number (bools and complex numbers
            are not).
        ValueError: naming the field, if a value makes no physical sense or
            cannot be simulated faithfully: a non-positive or non-finite value,
            one outside :data:`SUPPORTED_RANGES`, a robot as wide as a cell, a
            ``dt`` longer than a move, a move that is not a whole number of
            steps or takes more than :data:`MAX_STEPS_PER_MOVE`, a settle
            phase not shorter than the move, or a top speed that would cross
            more than the robot's radius in one step (the robot could then pass
            through a wall). Whether the controller keeps every promise is
            :func:`check_controller`'s to decide.
    """

    #: Side of one floor cell [m].
    cell_size: float = 1.0
    #: Radius of the round robot [m]; less than half a cell.
    robot_radius: float = 0.3
    #: Mass of the robot [kg]; its moment is that of a uniform disc.
    robot_mass: float = 20.0
    #: Floor drag [1/s]: a coasting robot's speed decays as ``exp(-floor_damping * t)``.
    floor_damping: float = 1.0
    #: Controller speed limit [m/s]: the pivot joint's ``max_bias``.
    max_speed: float = 6.0
    #: Controller force limit [N]: the pivot joint's ``max_force``.
    max_force: float = 3000.0
    #: Controller gain [1/s]: near its aim the robot closes the remaining distance
    #: at ``gain`` times that distance per second (the joint's ``error_bias`` is
    #: ``exp(-gain)``, the fraction of the error left after one second).
    gain: float = 60.0
    #: Length of one physics step [s]; constant, never taken from wall time.
    dt: float = 1 / 60
    #: Duration of one move [s]; a whole number of ``dt`` steps.
    move_duration: float = 0.25
    #: Last part of a move in which the robot settles on the centre nearest to it [s].
    settle_time: float = 0.1

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, (bool, np.bool_, np.timedelta64)) or not isinstance(
                value, (int, float, np.integer, np.floating)
            ):  # numpy counts durations as integers, without a unit we could read
                raise TypeError(
                    f"{field.name} must be a real number, got {value!r} ({type(value).__name__})"
                )
            try:
                number = float(value)
            except OverflowError:
                digits = len(str(abs(int(value))))
                raise ValueError(
                    f"{field.name} is too large: an integer of {digits} digits"
                ) from None
            if not math.isfinite(number) or number <= 0:
                raise ValueError(f"{field.name} must be positive and finite, got {value!r}")
            low, high = SUPPORTED_RANGES[field.name]
            if not low <= number <= high:
                raise ValueError(
                    f"{field.name} must be between {low:g} and {high:g} "
                    f"({_UNITS[field.name]}), got {number:g}"
                )
            object.__setattr__(self, field.name, number)  # plain floats: hashable, exact
        if self.robot_radius >= self.cell_size / 2:
            raise ValueError(
                f"robot_radius {self.robot_radius} m must be less than half the cell_size "
                f"{self.cell_size} m: the robot must fit in a cell"
            )
        if self.dt > self.move_duration:
            raise ValueError(
                f"dt {self.dt} s is longer than move_duration {self.move_duration} s: "
                "a move needs at least one physics step"
            )
        steps = self.move_duration / self.dt
        if abs(steps - round(steps)) > 1e-6 * steps:
            raise ValueError(
                f"move_duration {self.move_duration} s is not a whole number of dt={self.dt} s "
                f"steps ({steps:.4g}); one action must be a fixed number of physics steps"
            )
        if steps > MAX_STEPS_PER_MOVE:
            raise ValueError(
                f"move_duration {self.move_duration} s is {round(steps)} steps of dt={self.dt} s, "
                f"more than the {MAX_STEPS_PER_MOVE} a move may take; lengthen dt"
            )
        if not 1 <= self.settle_steps < self.steps_per_move:
            raise ValueError(
                f"settle_time {self.settle_time} s must be at least one step (dt={self.dt} s) "
                f"and shorter than move_duration {self.move_duration} s"
            )
        if self.max_speed * self.dt >= self.robot_radius:
            raise ValueError(
                f"max_speed {self.max_speed} m/s covers {self.max_speed * self.dt:.3g} m in one "
                f"step of dt={self.dt} s, not less than robot_radius {self.robot_radius} m: "
                "the robot could pass through a wall; lower max_speed or dt"
            )

    @property
    def steps_per_move(self) -> int:
        """Physics steps in one move."""
        return round(self.move_duration / self.dt)

    @property
    def settle_steps(self) -> int:
        """Physics steps of the settle phase, at the end of every move."""
        return round(self.settle_time / self.dt)

    @property
    def robot_diameter(self) -> float:
        """The robot's diameter [cells]."""
        return 2 * self.robot_radius / self.cell_size


#: The names of :class:`PhysicsConfig`'s fields: the physical keywords of every environment.
PHYSICS_FIELDS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(PhysicsConfig))


def physics_config_from(keywords: dict[str, Any]) -> PhysicsConfig:
    """The :class:`PhysicsConfig` of an environment's physical ``keywords``.

    Raises:
        TypeError: naming any keyword that is not a physical parameter, or a value
            of the wrong type; ValueError: as :class:`PhysicsConfig` does.
    """
    unknown = sorted(set(keywords) - set(PHYSICS_FIELDS))
    if unknown:
        raise TypeError(
            f"unknown argument(s) {', '.join(map(repr, unknown))}; the physical "
            f"parameters are {', '.join(PHYSICS_FIELDS)}"
        )
    return PhysicsConfig(**keywords)


class MoveResult(NamedTuple):
    """How a move ended: the cell read from the body, and how far it was from its centre."""

    cell: Cell
    #: Distance between the body and ``cell``'s centre just before the snap [cells].
    snap_error: float


class RobotBodies(NamedTuple):
    """What one robot is made of in a space: its body and disc, and its controller."""

    robot: pymunk.Body
    shape: pymunk.Circle
    #: The kinematic body on the point the robot is driven to.
    control: pymunk.Body
    #: The pivot joint that pulls the robot to ``control`` with capped force and speed.
    joint: pymunk.PivotJoint


def new_space(config: PhysicsConfig) -> pymunk.Space:
    """An empty space with the floor's drag, the contact slop for ``config``'s cells and
    one solver thread (the solver order, hence every bit, is then reproducible)."""
    space = pymunk.Space()
    space.threads = 1
    space.damping = math.exp(-config.floor_damping)  # fraction of velocity kept after 1 s
    # pymunk's default overlap allowance (0.1) suits pixel units; in metres it would
    # let the robot sink 10 cm into a wall.
    space.collision_slop = COLLISION_SLOP * config.cell_size
    return space


def add_floor(
    space: pymunk.Space,
    grid: WarehouseGrid,
    cell_size: float,
    origin: tuple[float, float] = (0.0, 0.0),
) -> None:
    """Add the walls around ``grid`` and its shelves to ``space``, with the floor's
    top-left corner at ``origin`` ``(x, y)`` [m]."""
    shapes = _wall_shapes(space.static_body, grid.rows, grid.cols, cell_size, origin)
    shapes += _shelf_shapes(space.static_body, grid.shelves, cell_size, origin)
    space.add(*shapes)


def add_robot(
    space: pymunk.Space, config: PhysicsConfig, position: tuple[float, float]
) -> RobotBodies:
    """Add a robot at rest on ``position`` ``(x, y)`` [m], and its controller aimed
    there, to ``space``."""
    robot = pymunk.Body()
    shape = pymunk.Circle(robot, config.robot_radius)
    shape.mass = config.robot_mass  # pymunk derives the moment of a uniform disc
    shape.friction = WALL_FRICTION
    shape.elasticity = 0.0
    robot.position = position
    space.add(robot, shape)

    # The controller: a kinematic body on the aim point, joined to the robot by
    # a pivot joint whose force and correction speed are capped.
    control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    control.position = robot.position
    joint = _new_joint(control, robot, config)
    space.add(control, joint)
    return RobotBodies(robot, shape, control, joint)


def renew_robot(
    space: pymunk.Space, config: PhysicsConfig, bodies: RobotBodies, position: tuple[float, float]
) -> RobotBodies:
    """Make ``bodies`` a robot as :func:`add_robot` builds it, at rest on ``position`` [m].

    Everything that carries state from one physics step to the next is reset
    or replaced: the disc leaves the space and comes back, dropping its cached
    contacts (and their accumulated impulses); the body gets a new body's
    state (position, no velocity, angle, spin, force or torque); the control
    body moves onto ``position``; a new joint, with no accumulated impulse,
    replaces the old one. The bodies keep their place in the space's list of
    bodies. The tests check that the robot then moves bit for bit as a newly
    built one. Returns the robot with its new joint.
    """
    space.remove(bodies.joint, bodies.shape)
    _reset_body(bodies.robot, position)
    _set_position(bodies.control, position)
    joint = _new_joint(bodies.control, bodies.robot, config)
    space.add(bodies.shape, joint)
    return bodies._replace(joint=joint)


def _new_joint(
    control: pymunk.Body, robot: pymunk.Body, config: PhysicsConfig
) -> pymunk.PivotJoint:
    """The controller's pivot joint: pulls ``robot`` to ``control``, force and speed capped."""
    joint = pymunk.PivotJoint(control, robot, (0, 0), (0, 0))
    joint.max_force = config.max_force
    joint.max_bias = config.max_speed
    joint.error_bias = math.exp(-config.gain)
    joint.collide_bodies = False
    return joint


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
        self.robot, self.robot_shape, self.control, self.joint = bodies
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
        _set_position(self.control, ((aim[1] + 0.5) * size, (aim[0] + 0.5) * size))
        x, y = self._advance(step, space, self._drive_steps)
        settle_on = (floor(y / size), floor(x / size))
        if settle_on != aim:  # a wall stopped the body: drive back to the centre it is nearest
            _set_position(self.control, ((settle_on[1] + 0.5) * size, (settle_on[0] + 0.5) * size))
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
        _place_at_rest(self.robot, centre)
        if cell != settle_on:
            _set_position(self.control, centre)
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
                path.append(_get_position(robot))
            return path[-1]
        for _ in range(steps):
            step(space, dt)
        return _get_position(self.robot)

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


def space_stepping(space: pymunk.Space) -> tuple[Callable[[Any, float], None], Any]:
    """How to advance ``space`` by ``dt``: ``step(target, dt)`` and its ``target``.

    chipmunk's ``cpSpaceStep`` on the space's C handle when pymunk exposes it
    (see ``_chipmunk``), else ``pymunk.Space.step`` on the space itself. The
    caller holds the handle only while it holds the space.
    """
    handle = getattr(space, "_space", None)
    if _CP_SPACE_STEP is None or handle is None:  # pragma: no cover - pymunk internals moved
        return pymunk.Space.step, space
    return _CP_SPACE_STEP, handle


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


def _chipmunk() -> Any:
    """chipmunk's C functions as pymunk binds them, or ``None`` if this pymunk hides them.

    ``Space.step`` wraps ``cpSpaceStep`` in queues and checks that matter only
    while bodies are being added or removed or collision callbacks run, and
    pymunk's body properties pass through a generic ``__setattr__`` and build a
    ``Vec2d`` on every read; a move needs none of that. Calling the C functions
    directly makes a move about half as costly. Every call reads the C handle
    from its pymunk object (``space._space``, ``body._body``) at that moment,
    so no handle outlives its object. Tests check that both ways give
    bit-identical paths.
    """
    try:
        from pymunk._chipmunk import lib
    except ImportError:  # pragma: no cover - depends on pymunk's internals
        return None
    needed = (
        "cpSpaceStep",
        "cpBodyGetPosition",
        "cpBodySetPosition",
        "cpBodySetVelocity",
        "cpBodySetAngularVelocity",
        "cpSpaceSetCurrentTimeStep",
        "cpBodySetAngle",
        "cpBodySetForce",
        "cpBodySetTorque",
    )
    return lib if all(hasattr(lib, name) for name in needed) else None


_LIB = _chipmunk()
_CP_SPACE_STEP = None if _LIB is None else _LIB.cpSpaceStep
#: Whether :meth:`PhysicsWorld.restart` can begin an episode exactly as a new world does.
CAN_RESTART = _LIB is not None

if _LIB is not None:

    def _get_position(body: pymunk.Body) -> tuple[float, float]:
        """The body's position ``(x, y)`` [m]."""
        position = _LIB.cpBodyGetPosition(body._body)
        return position.x, position.y

    def _set_position(body: pymunk.Body, position: tuple[float, float]) -> None:
        """Place the body at ``position`` [m] (as ``body.position = position``)."""
        _LIB.cpBodySetPosition(body._body, position)

    def clear_time_step(space: pymunk.Space) -> None:
        """Forget the space's last time step: its next step then applies no cached
        impulses, as the first step of a new space does."""
        _LIB.cpSpaceSetCurrentTimeStep(space._space, 0.0)

    def _place_at_rest(body: pymunk.Body, position: tuple[float, float]) -> None:
        """Place the body at ``position`` [m] with no linear or angular velocity."""
        handle = body._body
        _LIB.cpBodySetPosition(handle, position)
        _LIB.cpBodySetVelocity(handle, (0.0, 0.0))
        _LIB.cpBodySetAngularVelocity(handle, 0.0)

    def _reset_body(body: pymunk.Body, position: tuple[float, float]) -> None:
        """Give the body a new body's state on ``position`` [m]: at rest, angle 0,
        no force or torque."""
        handle = body._body
        _LIB.cpBodySetPosition(handle, position)
        _LIB.cpBodySetVelocity(handle, (0.0, 0.0))
        _LIB.cpBodySetAngle(handle, 0.0)
        _LIB.cpBodySetAngularVelocity(handle, 0.0)
        _LIB.cpBodySetForce(handle, (0.0, 0.0))
        _LIB.cpBodySetTorque(handle, 0.0)

else:  # pragma: no cover - the same through pymunk's properties

    def _get_position(body: pymunk.Body) -> tuple[float, float]:
        position = body.position
        return position.x, position.y

    def _set_position(body: pymunk.Body, position: tuple[float, float]) -> None:
        body.position = position

    def clear_time_step(space: pymunk.Space) -> None:
        raise RuntimeError("this pymunk cannot clear a space's time step: build a new world")

    def _place_at_rest(body: pymunk.Body, position: tuple[float, float]) -> None:
        body.position = position
        body.velocity = (0.0, 0.0)
        body.angular_velocity = 0.0

    def _reset_body(body: pymunk.Body, position: tuple[float, float]) -> None:
        _place_at_rest(body, position)
        body.angle = 0.0
        body.force = (0.0, 0.0)
        body.torque = 0.0


#: The body field of a position in pymunk's batched I/O.
POSITION_FIELD = pymunk.batch.BodyFields.POSITION


class PositionReader:
    """Every body's position in one call into chipmunk, into an array of our own.

    :func:`pymunk.batch.get_space_bodies` builds its call's arguments anew and
    fills a buffer that has to be copied out, every time; a recorded move reads
    positions after every physics step, so this reader keeps both: pymunk's own
    iterator function with a persistent argument block, filling our array. The
    array has room for three more numbers than the bodies need, because
    pymunk's buffer grows (and would move our memory) when fewer than three
    places are left; no body is ever added to a world's space after it is
    built. Without the pymunk internals this needs, it reads through
    :func:`pymunk.batch.get_space_bodies`.
    """

    def __init__(self, n_bodies: int) -> None:
        self.n_bodies = n_bodies
        self._floats = np.zeros(2 * n_bodies + 4)
        self._buffer = pymunk.batch.Buffer()
        self._buffer.set_float_buf(self._floats)
        self._positions = self._floats[: 2 * n_bodies].reshape(n_bodies, 2)
        try:
            from pymunk._chipmunk import ffi, lib

            data = ffi.new("pmBatchedData *")
            data.fields = POSITION_FIELD.value
            data.floatArray = self._buffer._float_arr
            data.intArray = self._buffer._int_arr
            iterate = ffi.addressof(lib, "pmSpaceBodyGetIteratorFuncBatched")
            self._call: tuple[Any, ...] | None = (lib.cpSpaceEachBody, iterate, data)
        except (ImportError, AttributeError):  # pragma: no cover - pymunk internals moved
            self._call = None

    def read(self, space: pymunk.Space) -> np.ndarray:
        """``(bodies, 2)`` positions ``(x, y)`` [m] in the space's order: a view, valid
        until the next read."""
        if self._call is None:  # pragma: no cover - pymunk internals moved
            buffer = pymunk.batch.Buffer()
            pymunk.batch.get_space_bodies(space, POSITION_FIELD, buffer)
            return np.frombuffer(buffer.float_buf(), dtype=np.float64).reshape(-1, 2)
        each_body, iterate, data = self._call
        floats = self._buffer._float_arr
        floats.num = 0
        each_body(space._space, iterate, data)
        if floats.num != 2 * self.n_bodies:  # pragma: no cover - a body was added
            raise RuntimeError(f"the space holds {floats.num // 2} bodies, not {self.n_bodies}")
        return self._positions


def _box(
    static_body: pymunk.Body, left: float, top: float, right: float, bottom: float
) -> pymunk.Poly:
    """A static box with the walls' surface, given by its edges [m]."""
    box = pymunk.Poly(static_body, [(left, top), (right, top), (right, bottom), (left, bottom)])
    box.friction = WALL_FRICTION
    box.elasticity = 0.0
    return box


def _shelf_shapes(
    static_body: pymunk.Body,
    shelves: frozenset[Cell],
    cell_size: float,
    origin: tuple[float, float],
) -> list[pymunk.Poly]:
    """One static box per horizontal run of shelf cells, each filling its cells exactly.

    A robot moving towards a shelf meets its edge half a cell from its own
    centre, exactly as it meets a wall. Merging runs keeps the number of
    shapes, hence the cost of building a world at every reset, small.
    """
    runs: list[list[int]] = []  # [row, first column, last column]
    for row, col in sorted(shelves):
        if runs and runs[-1][0] == row and runs[-1][2] == col - 1:
            runs[-1][2] = col
        else:
            runs.append([row, col, col])
    size, (x0, y0) = cell_size, origin
    return [
        _box(
            static_body,
            x0 + first * size,
            y0 + row * size,
            x0 + (last + 1) * size,
            y0 + (row + 1) * size,
        )
        for row, first, last in runs
    ]


def _wall_shapes(
    static_body: pymunk.Body, rows: int, cols: int, cell_size: float, origin: tuple[float, float]
) -> list[pymunk.Poly]:
    """Four thick boxes just outside the ``rows`` x ``cols`` floor, overlapping at the corners."""
    thick = WALL_THICKNESS * cell_size
    width, height = cols * cell_size, rows * cell_size
    boxes = (
        (-thick, -thick, width + thick, 0.0),  # top, above row 0
        (-thick, height, width + thick, height + thick),  # bottom
        (-thick, 0.0, 0.0, height),  # left
        (width, 0.0, width + thick, height),  # right
    )
    x0, y0 = origin
    return [
        _box(static_body, x0 + left, y0 + top, x0 + right, y0 + bottom)
        for left, top, right, bottom in boxes
    ]


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


#: The floor the controller is tried on: room to overshoot in every direction, walls
#: and a shelf to bump into along both axes.
_PROBE_FLOOR = WarehouseGrid.from_layout([".....", ".....", "...#.", ".....", "....."])
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
    (:func:`~warehouse_phys.traffic.check_clearance`).
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


@functools.cache
def check_controller(config: PhysicsConfig) -> ControllerMotion:
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
    for start, actions in _PROBES:
        world = PhysicsWorld(_PROBE_FLOOR, config, start, record_path=True)
        cell = start
        for action in actions:
            expected = _PROBE_FLOOR.move(cell, action)
            kind = "a free move" if expected != cell else "a bump into a wall or shelf"
            name = f"{kind} from {tuple(cell)} ({Action(action).name})"
            try:
                result = world.move(action)
            except RuntimeError as error:
                raise ValueError(f"with these settings {name} fails: {error}; {advice}") from None
            path = world.last_path
            depth = float(penetration(_PROBE_FLOOR, radius, path).max())
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
    return ControllerMotion(overshoot, bump_overshoot, drift)
