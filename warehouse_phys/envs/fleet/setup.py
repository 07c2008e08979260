"""How a fleet is set up from its arguments: each checked, its floor made from a layout or
read from a League of Robot Runners instance, its physical parameters checked, its
robots' placement.

:func:`set_up_fleet` refuses every argument of
:class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv` that cannot make a fleet, with an
error that names it (an instance's floor beside floor arguments too), before anything
is built, and returns what the arguments make (:class:`FleetSetup`).
:func:`fleet_placement` says where the robots start and what they may carry: an
instance's starts and errand list, or the floor's start cells, or cells drawn at every
reset (the rules are :mod:`warehouse_phys.world.placement`'s).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from warehouse_phys.envs.checks import number_text
from warehouse_phys.envs.fleet.observations import MAX_GLOBAL_OBSERVATION_ROBOTS, OBSERVATIONS
from warehouse_phys.lorr.errands import ErrandList, errand_list
from warehouse_phys.lorr.instances import LorrInstance, as_instance
from warehouse_phys.lorr.scheduling import Scheduler
from warehouse_phys.physics import PhysicsConfig, check_controller, physics_config_from
from warehouse_phys.physics.config import check_physics_robots, max_physics_robots
from warehouse_phys.world.grid import WarehouseGrid, refuse_durations
from warehouse_phys.world.headings import MOVE_MODELS
from warehouse_phys.world.layouts import make_grid, suggested_time_limit
from warehouse_phys.world.placement import (
    START_MODES,
    check_room,
    layout_starts,
    package_cells,
    reachable_cells,
)
from warehouse_phys.world.traffic import check_clearance, corner_follows_are_safe

__all__ = [
    "DELIVERY_MODES",
    "LORR_STEPS",
    "MAX_PHYSICS_ROBOTS",
    "FleetPlacement",
    "FleetSetup",
    "fleet_placement",
    "instance_of",
    "set_up_fleet",
]

DELIVERY_MODES = ("park", "leave", "new_package")
#: Most robots in the physics world: what this machine's memory holds
#: (:func:`~warehouse_phys.physics.config.max_physics_robots`).
MAX_PHYSICS_ROBOTS = max_physics_robots()
#: Most steps an episode may last (``max_cycles``).
MAX_CYCLES = 10**9
#: An instance fleet's ``max_cycles`` by default: the competition's 5,000 steps.
LORR_STEPS = 5000


@dataclass(frozen=True)
class FleetPlacement:
    """Where a fleet's robots start and what they may carry, as cell indices
    (``row * cols + col``)."""

    #: ``"layout"`` (the same start cells at every reset) or ``"random"`` (drawn).
    starts_mode: str
    #: The cells a package may be drawn on.
    targets: np.ndarray
    #: The cells reachable from the floor's start, where drawn robots may stand.
    reachable: np.ndarray
    #: The start cells of ``"layout"`` (an instance's starts); ``None`` when drawn.
    layout_starts: np.ndarray | None
    #: An instance fleet's errand list; ``None`` for a fleet that draws its packages.
    errands: ErrandList | None


@dataclass(frozen=True)
class FleetSetup:
    """What a fleet's checked arguments make (see
    :class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv`'s Arguments)."""

    #: The League of Robot Runners instance, read from its path; ``None`` without one.
    instance: LorrInstance | None
    grid: WarehouseGrid
    num_robots: int
    #: ``"park"``, ``"leave"`` or ``"new_package"`` (lifelong, and every instance fleet).
    on_delivery: str
    max_cycles: int
    #: The physical parameters when the robots are bodies; ``None`` in the grid twin.
    physics: PhysicsConfig | None
    #: Whether the traffic rule grants corner follows (robots small enough to pass).
    corner_follows: bool
    placement: FleetPlacement


def set_up_fleet(
    *,
    num_robots: object,
    physics: object,
    grid_rows: int | None,
    grid_cols: int | None,
    layout: str | Sequence[str] | None,
    lifelong: object,
    max_cycles: object,
    observation: object,
    render_mode: object,
    render_modes: Sequence[str],
    on_delivery: object,
    starts: object,
    track_gaps: object,
    moves: object,
    instance: LorrInstance | str | os.PathLike[str] | None,
    scheduler: Scheduler | None,
    record_errands: bool,
    physical: dict[str, float],
    safety: object = True,
) -> FleetSetup:
    """A fleet's arguments (those of :class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv`,
    ``render_modes`` the ones it renders, ``physical`` its physical keywords) checked,
    and what they make.

    Raises:
        TypeError, ValueError: naming the first argument that cannot make a fleet: a
            flag or choice, the instance beside floor arguments, the number of robots,
            a render mode, a limit of the physics world or the global observation, the
            floor, ``max_cycles``, the physical parameters (checked in both twins: the
            robots' size decides whether the rule grants corner follows; in the physics
            world the controller must keep one robot's promises, and the fleet's robots
            apart), and the floor's room for the fleet.
    """
    floor = {"grid_rows": grid_rows, "grid_cols": grid_cols, "layout": layout}
    instance, num_robots, lifelong = _checked_arguments(
        num_robots=num_robots, physics=physics, lifelong=lifelong, track_gaps=track_gaps,
        safety=safety,
        record_errands=record_errands, observation=observation, on_delivery=on_delivery,
        starts=starts, moves=moves, floor=floor, instance=instance, scheduler=scheduler,
        max_cycles=max_cycles, render_mode=render_mode, render_modes=render_modes,
    )  # fmt: skip
    grid = make_grid(grid_rows, grid_cols, layout) if instance is None else instance.grid
    on_delivery = "new_package" if lifelong else on_delivery or "park"
    max_cycles = _checked_max_cycles(max_cycles, grid, instance)
    config = physics_config_from(physical)
    if physics:  # the controller keeps one robot's promises, and the fleet's robots apart
        check_clearance(config.robot_diameter, *check_controller(config, turning=moves == "rotate"))
    placement = fleet_placement(grid, instance, num_robots, starts, on_delivery == "new_package",
                                scheduler, record_errands)  # fmt: skip
    return FleetSetup(
        instance, grid, num_robots, on_delivery, max_cycles, config if physics else None,
        corner_follows_are_safe(config.robot_diameter), placement,
    )  # fmt: skip


def _checked_arguments(
    *,
    num_robots: object,
    physics: object,
    lifelong: object,
    track_gaps: object,
    safety: object,
    record_errands: object,
    observation: object,
    on_delivery: object,
    starts: object,
    moves: object,
    floor: dict[str, object],
    instance: LorrInstance | str | os.PathLike[str] | None,
    scheduler: Scheduler | None,
    max_cycles: object,
    render_mode: object,
    render_modes: Sequence[str],
) -> tuple[LorrInstance | None, int, bool]:
    """The fleet's ``(instance, num_robots, lifelong)``: the instance read from its path
    (``None`` without one), the number of robots (an instance's ``teamSize`` by default,
    else 2) and whether the robots are lifelong (an instance fleet's always are).

    ``floor`` holds the floor arguments (``grid_rows``, ``grid_cols``, ``layout``), refused
    beside an instance; ``max_cycles`` is refused here only when it is a duration (the
    rest of its check waits for the floor, :func:`_checked_max_cycles`).

    Raises:
        TypeError, ValueError: naming the first argument that cannot make a fleet,
            in the order of the checks below.
    """
    flags = (("physics", physics), ("lifelong", lifelong), ("track_gaps", track_gaps),
             ("safety", safety), ("record_errands", record_errands))  # fmt: skip
    for name, flag in flags:
        if not isinstance(flag, bool):
            raise TypeError(f"{name} must be a bool, got {flag!r}")
    for name, value, choices in (
        ("observation", observation, OBSERVATIONS),
        ("on_delivery", "park" if on_delivery is None else on_delivery, DELIVERY_MODES),
        ("starts", starts, START_MODES),
        ("moves", moves, MOVE_MODELS),
    ):
        if not isinstance(value, str) or value not in choices:
            raise ValueError(f"{name} must be one of {list(choices)}, got {value!r}")
    instance = instance_of(instance, floor, starts, scheduler)
    if instance is not None:
        if on_delivery not in (None, "new_package"):
            raise ValueError(
                f"an instance fleet is lifelong (its robots take the task list's errands); "
                f"got on_delivery={on_delivery!r}"
            )
        lifelong = True
        num_robots = instance.team_size if num_robots is None else num_robots
    num_robots = 2 if num_robots is None else num_robots
    refuse_durations(num_robots=num_robots, max_cycles=max_cycles)
    if isinstance(num_robots, bool) or not isinstance(num_robots, (int, np.integer)):
        raise TypeError(f"num_robots must be an integer, got {num_robots!r}")
    if num_robots < 1:
        raise ValueError(f"num_robots must be at least 1, got {number_text(num_robots)}")
    if instance is not None and num_robots != instance.team_size:
        raise ValueError(
            f"num_robots={num_robots} but the instance {instance.name} has teamSize "
            f"{instance.team_size}; leave num_robots out"
        )
    if lifelong and on_delivery not in (None, "new_package"):
        raise ValueError(
            f"lifelong=True means on_delivery='new_package'; got on_delivery={on_delivery!r}"
        )
    if render_mode is not None and render_mode not in render_modes:
        raise ValueError(f"render_mode must be None or one of {render_modes}, got {render_mode!r}")
    _check_limits(int(num_robots), physics, on_delivery, observation)
    return instance, int(num_robots), lifelong


def _check_limits(num_robots: int, physics: bool, on_delivery: object, observation: str) -> None:
    """Refuse what the physics world or the ``"global"`` observation cannot take."""
    if physics:
        check_physics_robots(num_robots)
    if physics and on_delivery == "leave":
        raise ValueError(
            "on_delivery='leave' is for the grid twin: in the physics world a robot's "
            "body cannot leave the floor yet; use 'park' or 'new_package'"
        )
    if observation == "global" and num_robots > MAX_GLOBAL_OBSERVATION_ROBOTS:
        raise ValueError(
            f"observation='global' takes at most {MAX_GLOBAL_OBSERVATION_ROBOTS} robots "
            f"(each robot's copy holds 4 numbers per robot: {num_robots:,} robots would need "
            f"{32 * int(num_robots) ** 2 / 2**20:,.0f} MiB a step); use 'local' or "
            "'neighbours'"
        )


def _checked_max_cycles(
    max_cycles: object, grid: WarehouseGrid, instance: LorrInstance | None
) -> int:
    """``max_cycles`` as an int of at least 1; by default an instance fleet's
    :data:`LORR_STEPS`, else :func:`~warehouse_phys.world.layouts.suggested_time_limit`
    of ``grid``.

    Raises:
        TypeError, ValueError: naming ``max_cycles``.
    """
    if max_cycles is None:
        max_cycles = LORR_STEPS if instance is not None else suggested_time_limit(grid)
    if isinstance(max_cycles, bool) or not isinstance(max_cycles, (int, np.integer)):
        raise TypeError(f"max_cycles must be an integer, got {max_cycles!r}")
    if not 1 <= max_cycles <= MAX_CYCLES:
        raise ValueError(f"max_cycles must be 1 to {MAX_CYCLES:,}, got {number_text(max_cycles)}")
    return int(max_cycles)


def instance_of(
    instance: LorrInstance | str | os.PathLike[str] | None,
    floor: dict[str, object],
    starts: str,
    scheduler: Scheduler | None,
) -> LorrInstance | None:
    """``instance`` as a :class:`LorrInstance` (read from its path), with the fleet's
    floor arguments (``floor``: those given) refused beside it."""
    if instance is None:
        if scheduler is not None:
            raise ValueError("scheduler is for a fleet of an instance (instance=...)")
        return None
    given = [name for name, value in floor.items() if value is not None]
    if given or starts != "auto":
        names = ", ".join(given + ([] if starts == "auto" else ["starts"]))
        raise ValueError(f"an instance gives the floor and the starts; do not give {names}")
    return as_instance(instance)


def fleet_placement(
    grid: WarehouseGrid,
    instance: LorrInstance | None,
    num_robots: int,
    starts: str,
    lifelong: bool,
    scheduler: Scheduler | None = None,
    record_errands: bool = False,
) -> FleetPlacement:
    """The placement of ``num_robots`` robots on ``grid`` (``starts``: ``"auto"``,
    ``"layout"`` or ``"random"``, see :data:`~warehouse_phys.world.placement.START_MODES`),
    or of ``instance``'s robots, whose errands are handed out by ``scheduler``
    (``record_errands``: keep the events the competition's output file lists).

    Raises:
        ValueError: if the floor has no room for the fleet
            (:func:`~warehouse_phys.world.placement.check_room`, which gives the counts).
    """
    errands: ErrandList | None = None
    if instance is not None:
        starts = "layout"
        errands = errand_list(instance, scheduler=scheduler, record=record_errands)
    elif starts == "auto":
        starts = "layout" if getattr(grid, "starts_marked", True) else "random"
    targets = package_cells(grid)
    reachable = reachable_cells(grid)
    layout_starts_index = None
    if instance is not None:
        layout_starts_index = instance.starts
    elif starts == "layout":
        layout_starts_index = layout_starts(grid, num_robots, reachable)
    if instance is None:
        check_room(num_robots, starts, lifelong, targets, reachable, layout_starts_index)
    return FleetPlacement(starts, targets, reachable, layout_starts_index, errands)
