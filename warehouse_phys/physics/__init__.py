"""The physics floor: robots as pymunk rigid bodies, driven cell to cell and snapped.

- :mod:`~warehouse_phys.physics.config`: the physical parameters and the promised bounds;
- :mod:`~warehouse_phys.physics.engine`: every call into pymunk and chipmunk;
- :mod:`~warehouse_phys.physics.world`: one robot's world (the single environment's);
- :mod:`~warehouse_phys.physics.controller`: the check that a setting keeps every promise;
- :mod:`~warehouse_phys.physics.batched`: many robots in one space (vector envs, fleets),
  on the floors of :mod:`~warehouse_phys.physics.floor_lattice`, moved in lock step by
  :mod:`~warehouse_phys.physics.lockstep`, read and written through
  :mod:`~warehouse_phys.physics.body_io`;
- :mod:`~warehouse_phys.physics.ticking`: bodies driven tick by tick between cells
  (asynchronous execution) and the clearance formula; a tick's arguments are checked by
  :mod:`~warehouse_phys.physics.tick_arguments`, the tick controller check is
  :mod:`~warehouse_phys.physics.tick_controller`;
- :mod:`~warehouse_phys.physics.regions`: the floor split into regions, a space each,
  stepped in parallel threads (``BatchedPhysicsWorld(threads=K)``);
- :mod:`~warehouse_phys.physics.safety`: the bodies' closest approach and contacts deeper
  than the collision slop, measured at every physics step.

The names of the first four are importable from here, as they were from the
single module this package replaces.
"""

from __future__ import annotations

from warehouse_phys.physics.config import (
    HEADING_SNAP_BOUND,
    MAX_STEPS_PER_MOVE,
    PENETRATION_TOLERANCE,
    PHYSICS_FIELDS,
    SNAP_ERROR_BOUND,
    SUPPORTED_RANGES,
    PhysicsConfig,
    physics_config_from,
)
from warehouse_phys.physics.controller import (
    ControllerMotion,
    check_controller,
    penetration,
    speed_profile,
)
from warehouse_phys.physics.engine import (
    CAN_RESTART,
    COLLISION_SLOP,
    POSITION_FIELD,
    WALL_FRICTION,
    WALL_THICKNESS,
    PositionReader,
    RobotBodies,
    add_floor,
    add_robot,
    clear_time_step,
    get_position,
    new_space,
    place_at_rest,
    renew_robot,
    reset_body,
    set_position,
    space_stepping,
)
from warehouse_phys.physics.world import (
    MoveResult,
    PhysicsWorld,
)

__all__ = [
    "CAN_RESTART",
    "COLLISION_SLOP",
    "HEADING_SNAP_BOUND",
    "MAX_STEPS_PER_MOVE",
    "PENETRATION_TOLERANCE",
    "PHYSICS_FIELDS",
    "POSITION_FIELD",
    "SNAP_ERROR_BOUND",
    "SUPPORTED_RANGES",
    "WALL_FRICTION",
    "WALL_THICKNESS",
    "ControllerMotion",
    "MoveResult",
    "PhysicsConfig",
    "PhysicsWorld",
    "PositionReader",
    "RobotBodies",
    "add_floor",
    "add_robot",
    "check_controller",
    "clear_time_step",
    "get_position",
    "new_space",
    "penetration",
    "physics_config_from",
    "place_at_rest",
    "renew_robot",
    "reset_body",
    "set_position",
    "space_stepping",
    "speed_profile",
]
