"""The physics engine: every call into pymunk and chipmunk.

Spaces with the floor's drag and contact slop, static walls and shelves, a robot's
body, disc, control body and pivot joint (built and renewed), and the fast paths
into chipmunk's C functions (stepping, reading and placing bodies, clearing a
space's time step, batched position reads). No other module of the package reaches
into pymunk's internals; the single world and the batched world are both built
from these functions.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
import pymunk
import pymunk.batch

from warehouse_phys.physics.config import PhysicsConfig
from warehouse_phys.world.grid import WarehouseGrid

#: Thickness of the static walls around the floor [cells]. A wall this thick
#: cannot be crossed in one physics step (steps are shorter than the robot's radius).
WALL_THICKNESS = 1.0


#: Overlap pymunk allows between touching shapes, to keep contacts steady [cells].
COLLISION_SLOP = 0.002


#: Friction coefficient of robot-wall contacts (rubber bumper on steel) [1].
WALL_FRICTION = 0.6


class RobotBodies(NamedTuple):
    """What one robot is made of in a space: its body and disc, and its controller."""

    robot: pymunk.Body
    shape: pymunk.Circle
    #: The kinematic body on the point the robot is driven to.
    control: pymunk.Body
    #: The pivot joint that pulls the robot to ``control`` with capped force and speed.
    joint: pymunk.PivotJoint
    #: A turning robot's gear joint, which turns it to ``control``'s angle with capped
    #: torque and spin; ``None`` for a robot that does not turn.
    gear: pymunk.GearJoint | None = None


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
    shapes += _shelf_shapes(space.static_body, grid.shelf_mask, cell_size, origin)
    space.add(*shapes)


def add_robot(
    space: pymunk.Space,
    config: PhysicsConfig,
    position: tuple[float, float],
    angle: float | None = None,
) -> RobotBodies:
    """Add a robot at rest on ``position`` ``(x, y)`` [m], and its controller aimed
    there, to ``space``; a turning robot (``angle`` [rad], clockwise from east as rows
    grow downwards) also gets a gear joint that holds it at its control body's angle."""
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
    if angle is None:
        return RobotBodies(robot, shape, control, joint)
    robot.angle = control.angle = angle
    gear = _new_gear(control, robot, config)
    space.add(gear)
    return RobotBodies(robot, shape, control, joint, gear)


def renew_robot(
    space: pymunk.Space,
    config: PhysicsConfig,
    bodies: RobotBodies,
    position: tuple[float, float],
    angle: float | None = None,
) -> RobotBodies:
    """Make ``bodies`` a robot as :func:`add_robot` builds it, at rest on ``position`` [m]
    (a turning robot facing ``angle`` [rad], with a new gear joint).

    Everything that carries state from one physics step to the next is reset
    or replaced: the disc leaves the space and comes back, dropping its cached
    contacts (and their accumulated impulses); the body gets a new body's
    state (position, no velocity, angle, spin, force or torque); the control
    body moves onto ``position``; a new joint, with no accumulated impulse,
    replaces the old one. The bodies keep their place in the space's list of
    bodies. The tests check that the robot then moves bit for bit as a newly
    built one. Returns the robot with its new joint.
    """
    if _RENEW_IN_PLACE is not None and bodies.gear is None:
        # A vector env renews several robots a step: chipmunk's own calls cost a third of
        # pymunk's remove, new joint and add, with the same effect (see _in_place_renewal).
        _RENEW_IN_PLACE(space, config, bodies, position)
        return bodies
    space.remove(bodies.joint, bodies.shape)
    if bodies.gear is not None:
        space.remove(bodies.gear)
    reset_body(bodies.robot, position)
    set_position(bodies.control, position)
    joint = _new_joint(bodies.control, bodies.robot, config)
    space.add(bodies.shape, joint)
    if bodies.gear is None or angle is None:
        return bodies._replace(joint=joint)
    bodies.robot.angle = bodies.control.angle = angle
    gear = _new_gear(bodies.control, bodies.robot, config)
    space.add(gear)
    return bodies._replace(joint=joint, gear=gear)


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


def _new_gear(control: pymunk.Body, robot: pymunk.Body, config: PhysicsConfig) -> pymunk.GearJoint:
    """A turning robot's gear joint: turns ``robot`` to ``control``'s angle with the pivot
    joint's limits at the disc's rim (torque ``max_force x radius``, spin
    ``max_speed / radius``) and its gain."""
    gear = pymunk.GearJoint(control, robot, 0.0, 1.0)
    gear.max_force = config.max_force * config.robot_radius  # [N m]
    gear.max_bias = config.max_speed / config.robot_radius  # [rad/s]
    gear.error_bias = math.exp(-config.gain)
    gear.collide_bodies = False
    return gear


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


#: Whether :meth:`~warehouse_phys.physics.world.PhysicsWorld.restart` can begin an episode
#: exactly as a new world does.
CAN_RESTART = _LIB is not None


def _in_place_renewal() -> Callable[..., None] | None:
    """:func:`renew_robot` for a robot that does not turn, through chipmunk's own calls,
    or ``None`` if this pymunk does not expose them.

    The joint is taken out of the space and the disc with it (which drops the disc's
    cached contacts), the joint is initialised anew where it lies
    (``cpPivotJointInit``: no accumulated impulse, exactly as ``cpPivotJointNew2``
    leaves a new one) and given the controller's limits, then the disc and the joint
    go back in the same order as ``space.add``. Chipmunk's arrays and broad phase then
    hold what pymunk's remove-and-add leaves there (a removed constraint's place is
    taken by the last one, the re-added one goes last), so every bit of every later
    step is the same; pymunk's own lists are untouched, as the objects never leave.
    """
    try:
        from pymunk._chipmunk import ffi
    except ImportError:  # pragma: no cover - depends on pymunk's internals
        return None
    needed = (
        "cpSpaceRemoveConstraint",
        "cpSpaceRemoveShape",
        "cpSpaceAddShape",
        "cpSpaceAddConstraint",
        "cpPivotJointInit",
        "cpConstraintSetMaxForce",
        "cpConstraintSetMaxBias",
        "cpConstraintSetErrorBias",
        "cpConstraintSetCollideBodies",
    )
    if _LIB is None or not all(hasattr(_LIB, name) for name in needed):
        return None  # pragma: no cover - depends on pymunk's internals
    lib, origin = _LIB, (0.0, 0.0)

    def renew(
        space: pymunk.Space,
        config: PhysicsConfig,
        bodies: RobotBodies,
        position: tuple[float, float],
    ) -> None:
        handle, joint, shape = space._space, bodies.joint._constraint, bodies.shape._shape
        lib.cpSpaceRemoveConstraint(handle, joint)
        lib.cpSpaceRemoveShape(handle, shape)
        reset_body(bodies.robot, position)
        set_position(bodies.control, position)
        control, robot = bodies.control._body, bodies.robot._body
        lib.cpPivotJointInit(ffi.cast("cpPivotJoint *", joint), control, robot, origin, origin)
        # The limits _new_joint gives a new joint (the user data, pymunk's handle, stays).
        lib.cpConstraintSetMaxForce(joint, config.max_force)
        lib.cpConstraintSetMaxBias(joint, config.max_speed)
        lib.cpConstraintSetErrorBias(joint, math.exp(-config.gain))
        lib.cpConstraintSetCollideBodies(joint, False)
        lib.cpSpaceAddShape(handle, shape)
        lib.cpSpaceAddConstraint(handle, joint)

    return renew


if _LIB is not None:

    def get_position(body: pymunk.Body) -> tuple[float, float]:
        """The body's position ``(x, y)`` [m]."""
        position = _LIB.cpBodyGetPosition(body._body)
        return position.x, position.y

    def set_position(body: pymunk.Body, position: tuple[float, float]) -> None:
        """Place the body at ``position`` [m] (as ``body.position = position``)."""
        _LIB.cpBodySetPosition(body._body, position)

    def clear_time_step(space: pymunk.Space) -> None:
        """Forget the space's last time step: its next step then applies no cached
        impulses, as the first step of a new space does."""
        _LIB.cpSpaceSetCurrentTimeStep(space._space, 0.0)

    def place_at_rest(body: pymunk.Body, position: tuple[float, float]) -> None:
        """Place the body at ``position`` [m] with no linear or angular velocity."""
        handle = body._body
        _LIB.cpBodySetPosition(handle, position)
        _LIB.cpBodySetVelocity(handle, (0.0, 0.0))
        _LIB.cpBodySetAngularVelocity(handle, 0.0)

    def reset_body(body: pymunk.Body, position: tuple[float, float]) -> None:
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

    def get_position(body: pymunk.Body) -> tuple[float, float]:
        position = body.position
        return position.x, position.y

    def set_position(body: pymunk.Body, position: tuple[float, float]) -> None:
        body.position = position

    def clear_time_step(space: pymunk.Space) -> None:
        raise RuntimeError("this pymunk cannot clear a space's time step: build a new world")

    def place_at_rest(body: pymunk.Body, position: tuple[float, float]) -> None:
        body.position = position
        body.velocity = (0.0, 0.0)
        body.angular_velocity = 0.0

    def reset_body(body: pymunk.Body, position: tuple[float, float]) -> None:
        place_at_rest(body, position)
        body.angle = 0.0
        body.force = (0.0, 0.0)
        body.torque = 0.0


_RENEW_IN_PLACE = _in_place_renewal()


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
    built, unless the reader has room for more (``capacity`` bodies, then
    :meth:`resize` after bodies come or go: a region's space of
    :mod:`~warehouse_phys.physics.regions`). Without the pymunk internals this
    needs, it reads through :func:`pymunk.batch.get_space_bodies`.
    """

    def __init__(self, n_bodies: int, *, angles: bool = False, capacity: int = 0) -> None:
        #: Numbers read per body: ``x, y``, and the angle with ``angles=True``.
        self.width = width = 3 if angles else 2
        fields = POSITION_FIELD | pymunk.batch.BodyFields.ANGLE if angles else POSITION_FIELD
        self._fields = fields
        self._floats = np.zeros(width * max(n_bodies, capacity) + 4)
        self._buffer = pymunk.batch.Buffer()
        self._buffer.set_float_buf(self._floats)
        self.resize(n_bodies)
        try:
            from pymunk._chipmunk import ffi, lib

            data = ffi.new("pmBatchedData *")
            data.fields = fields.value
            data.floatArray = self._buffer._float_arr
            data.intArray = self._buffer._int_arr
            iterate = ffi.addressof(lib, "pmSpaceBodyGetIteratorFuncBatched")
            self._call: tuple[Any, ...] | None = (lib.cpSpaceEachBody, iterate, data)
        except (ImportError, AttributeError):  # pragma: no cover - pymunk internals moved
            self._call = None

    def resize(self, n_bodies: int) -> None:
        """Read ``n_bodies`` bodies from now on (at most the capacity it was built with)."""
        width = self.width
        if width * n_bodies + 4 > len(self._floats):
            raise ValueError(f"this reader has room for {(len(self._floats) - 4) // width} bodies")
        self.n_bodies = n_bodies
        self._positions = self._floats[: width * n_bodies].reshape(n_bodies, width)

    def read(self, space: pymunk.Space) -> np.ndarray:
        """``(bodies, 2)`` positions ``(x, y)`` [m] in the space's order (``(bodies, 3)``
        with the angle [rad] after them, for a reader of angles): a view, valid until the
        next read."""
        width = self.width
        if self._call is None:  # pragma: no cover - pymunk internals moved
            buffer = pymunk.batch.Buffer()
            pymunk.batch.get_space_bodies(space, self._fields, buffer)
            return np.frombuffer(buffer.float_buf(), dtype=np.float64).reshape(-1, width)
        each_body, iterate, data = self._call
        floats = self._buffer._float_arr
        floats.num = 0
        each_body(space._space, iterate, data)
        if floats.num != width * self.n_bodies:  # pragma: no cover - a body was added
            raise RuntimeError(f"the space holds {floats.num // width} bodies, not {self.n_bodies}")
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
    shelf_mask: np.ndarray,
    cell_size: float,
    origin: tuple[float, float],
) -> list[pymunk.Poly]:
    """One static box per horizontal run of shelf cells (``shelf_mask``, ``(rows, cols)``
    bool), in reading order, each filling its cells exactly.

    A robot moving towards a shelf meets its edge half a cell from its own
    centre, exactly as it meets a wall. Merging runs keeps the number of
    shapes, hence the cost of building a world at every reset, small.
    """
    # The runs found on the mask rather than cell by cell: a third of the time a big
    # floor took (warehouse-large's 31,414 shelf cells, 10,448 runs), in every space.
    # edges[r, c] = mask[r, c] - mask[r, c - 1], with no shelf beyond either side (by
    # slices: np.diff's prepend and append cost more than a small floor's whole loop).
    edges = np.zeros((shelf_mask.shape[0], shelf_mask.shape[1] + 1), dtype=np.int8)
    edges[:, :-1] = shelf_mask
    edges[:, 1:] -= shelf_mask
    rows, firsts = np.nonzero(edges == 1)  # row-major: the runs in reading order
    ends = np.nonzero(edges == -1)[1]  # the column after each run's last
    size, (x0, y0) = cell_size, origin
    return [
        _box(
            static_body, x0 + first * size, y0 + row * size, x0 + end * size, y0 + (row + 1) * size
        )
        for row, first, end in zip(rows.tolist(), firsts.tolist(), ends.tolist(), strict=True)
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
