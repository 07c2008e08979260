"""The physical parameters of a robot, its controller and the physics clock, and the
bounds every environment promises (:data:`SNAP_ERROR_BOUND`, :data:`PENETRATION_TOLERANCE`).

Pure: a frozen dataclass checked on construction. Whether a setting keeps every
promise is :func:`~warehouse_phys.physics.controller.check_controller`'s to decide.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

#: Largest distance between the body and the centre it is snapped to at the end
#: of a move, in cells, that the environment promises for every move [cells].
SNAP_ERROR_BOUND = 0.02


#: Largest angle between a turning robot's body and the heading it is snapped to at the
#: end of a move, that the turning fleet promises for every move [rad] (about 1.1 degrees).
HEADING_SNAP_BOUND = 0.02


#: Deepest the robot's disc may go into a wall or a shelf at any physics step [cells]:
#: as far as the default robot travels in one step. Contacts are solved after the
#: overlap they resolve, so a bump always sinks in a little: the defaults reach 0.024,
#: a controller of 10,000 N about 0.1.
PENETRATION_TOLERANCE = 0.1


#: Most physics steps in one move: no setting may make an action cost more.
MAX_STEPS_PER_MOVE = 1000


#: Memory the physics world takes a robot, rounded up from what it measured [bytes]:
#: chipmunk's and pymunk's bodies, disc, joints and tree leaves, the batched buffers,
#: a tick's recorded path and the safety measures (12 KiB a robot at 10,000 robots,
#: 9 KiB at 40,000; ``benchmarks/physics_scale.py``).
PHYSICS_BYTES_PER_ROBOT = 16 * 1024


def machine_memory() -> int:
    """This machine's physical memory [bytes] (64 GiB where the system does not say)."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
        return 64 * 2**30


def max_physics_robots() -> int:
    """Most robots one physics world holds on this machine: its memory over
    :data:`PHYSICS_BYTES_PER_ROBOT`."""
    return machine_memory() // PHYSICS_BYTES_PER_ROBOT


def check_physics_robots(num_robots: int, name: str = "num_robots") -> int:
    """``num_robots`` if this machine's memory holds their bodies, else a ``ValueError``
    naming ``name``, the memory they need and the machine's."""
    most = max_physics_robots()
    if num_robots > most:
        need = _memory_text(num_robots * PHYSICS_BYTES_PER_ROBOT)
        raise ValueError(
            f"{name}: {num_robots:,} robots' bodies need about {need} "
            f"({PHYSICS_BYTES_PER_ROBOT // 1024} KiB a robot), more than this machine's "
            f"{_memory_text(machine_memory())}: the physics world holds at most {most:,}"
        )
    return num_robots


def _memory_text(n_bytes: int) -> str:
    """``n_bytes`` in GiB, or in MiB below 1 GiB, to a tenth."""
    if n_bytes < 2**30:
        return f"{n_bytes / 2**20:,.1f} MiB"
    return f"{n_bytes / 2**30:,.1f} GiB"


#: The values each setting may take, (lowest, highest), in its unit. Outside them
#: the simulation loses precision or overflows; inside them the controller check
#: (:func:`~warehouse_phys.physics.controller.check_controller`) decides whether a setting
#: keeps every promise.
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
            :func:`~warehouse_phys.physics.controller.check_controller`'s to decide.
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
