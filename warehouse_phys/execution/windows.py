"""Plans for asynchronous execution: windows of PIBT steps, with their rotations taken out.

:func:`pibt_window` asks a :class:`~warehouse_phys.planners.pibt.PIBT` planner (or a
:class:`~warehouse_phys.planners.guidance.GuidedPIBT`, :func:`window_planner` by name) for a
few lock-step steps in a row, each from the cells (and headings) its last step leads
to, in the form :meth:`~warehouse_phys.execution.executor.Executor.add_plan` takes. A
rotation (robots each entering the cell the next one leaves, round a cycle) can be run
by the executor only when its robots' moves take the same ticks; for other fleets
``rotations=False`` plans each step again with one robot of each rotation asked to wait
(so that the others go round it) and holds what rotations remain
(:func:`without_rotations`). A guided planner takes no ``requests``: the robots asked to
wait are held after its plan instead, with every robot that would enter the cell of one
held, down its chain (:func:`held_back`), and a step with rotations is not planned again
(its rotations are held). Like :mod:`warehouse_phys.world.grid`, this module imports
neither gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from warehouse_phys.execution.plan_checks import NO_ROBOT, and_along, checked_cells, rows_cols
from warehouse_phys.planners.guidance import GuidedPIBT
from warehouse_phys.planners.named import PLANNERS, named_planner
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import HEADING_MOVES, TurnAction, turned
from warehouse_phys.world.traffic import WAIT, neighbour_table

#: Times :func:`pibt_window` plans a step again to take rotations out of it.
REPLANS = 3
#: The planners of the windows by name (:func:`window_planner`): every planner of
#: :mod:`warehouse_phys.planners.named` (those of its ``TURNING_ONLY`` for turning robots).
WINDOW_PLANNERS = PLANNERS


def window_planner(
    name: str, grid: WarehouseGrid, *, moves: str = "grid", seed: int = 0, **guidance: Any
) -> PIBT | GuidedPIBT:
    """The planner of :data:`WINDOW_PLANNERS` called ``name`` for ``grid`` and ``moves``,
    with a guided planner's fields ``guidance``
    (:func:`~warehouse_phys.planners.named.named_planner`).

    Raises:
        ValueError: for another name, guidance given to plain PIBT, or a planner of
            turning robots only with ``moves`` other than ``"rotate"``.
        TypeError: naming a field the planner lacks.
    """
    return named_planner(name, grid, moves=moves, seed=seed, **guidance)


def pibt_window(
    planner: PIBT,
    cells: np.ndarray,
    goals: np.ndarray,
    steps: int,
    *,
    headings: np.ndarray | None = None,
    rotations: bool = True,
    **plan_options: object,
) -> np.ndarray:
    """A lock-step plan of ``steps`` steps from ``cells`` (``(N, 2)``, and turning
    robots' ``headings``, ``(N,)``): ``planner`` asked ``steps`` times, each time on the
    cells its last plan leads to, towards ``goals``. ``plan_options`` go to every
    :meth:`~warehouse_phys.planners.pibt.PIBT.plan` call.

    With ``rotations=False`` no step rotates: a step whose plan has rotations is planned
    again with one robot of each (the lowest-numbered) asked to wait, up to
    :data:`REPLANS` times; rotations left after that are held (:func:`without_rotations`).

    Returns:
        ``(N, steps + 1, 2)`` int64, each robot's ``(row, col)`` at each step, for
        :meth:`~warehouse_phys.execution.executor.Executor.add_plan`; turning robots
        ``(N, steps + 1, 3)``, ``(row, col, heading)``.

    Raises:
        ValueError: if ``headings`` are missing for a turning planner or given to another.
    """
    pibt = planner.pibt if isinstance(planner, GuidedPIBT) else planner
    if pibt.turning != (headings is not None):
        raise ValueError("headings: a turning planner (moves='rotate') needs them, no other")
    grid = pibt.grid
    here = checked_cells(grid, cells)
    facing = None if headings is None else np.asarray(headings, dtype=np.int64).copy()
    path = np.empty((len(here), steps + 1), dtype=np.int64)
    faces = np.empty_like(path)
    path[:, 0] = here
    faces[:, 0] = 0 if facing is None else facing
    occupant = np.full(grid.rows * grid.cols, NO_ROBOT, dtype=np.int64)
    asked = dict(plan_options.pop("requests", None) or {})
    for s in range(steps):
        wanted, facing = _one_step(planner, here, facing, goals, asked, rotations, occupant,
                                   plan_options)  # fmt: skip
        here = wanted if rotations else without_rotations(here, wanted, occupant)
        path[:, s + 1] = here
        faces[:, s + 1] = 0 if facing is None else facing
    plan = rows_cols(path, grid.cols)
    return plan if headings is None else np.concatenate([plan, faces[..., None]], axis=2)


def _one_step(
    planner: PIBT | GuidedPIBT,
    here: np.ndarray,
    facing: np.ndarray | None,
    goals: np.ndarray,
    asked: dict[int, int],
    rotations: bool,
    occupant: np.ndarray,
    plan_options: dict[str, object],
) -> tuple[np.ndarray, np.ndarray | None]:
    """One step of the window: the cells each robot wants and the headings after it,
    planned again (up to :data:`REPLANS` times) while it has rotations to take out."""
    grid = planner.pibt.grid if isinstance(planner, GuidedPIBT) else planner.grid
    table = neighbour_table(grid)
    wait = TurnAction.WAIT if facing is not None else WAIT
    requests = dict(asked)
    options = dict(plan_options) if facing is None else {**plan_options, "headings": facing}
    if isinstance(planner, GuidedPIBT):  # no requests: the asked robots are held after
        actions = planner.plan(rows_cols(here, grid.cols), goals, **options)
        hold = np.zeros(len(here), dtype=bool)
        hold[list(requests)] = True
        actions = np.where(hold, wait, actions)
        if facing is None:
            wanted, after = table[here, actions], None
        else:
            wanted = np.where(actions == TurnAction.FORWARD, table[here, HEADING_MOVES[facing]],
                              here)  # fmt: skip
        kept = held_back(here, wanted, occupant, hold)
        if facing is not None:
            actions = np.where((kept != wanted), wait, actions)
            after = turned(facing, actions)
        return kept, after
    for attempt in range(REPLANS + 1):
        actions = planner.plan(rows_cols(here, planner.grid.cols), goals, requests=requests,
                               **options)  # fmt: skip
        if facing is None:
            wanted, after = table[here, actions], None
        else:
            forward = actions == TurnAction.FORWARD
            wanted = np.where(forward, table[here, HEADING_MOVES[facing]], here)
            after = turned(facing, actions)
        heads = rotation_heads(here, wanted, occupant) if not rotations else ()
        if not len(heads) or attempt == REPLANS:
            return wanted, after
        requests.update(dict.fromkeys(np.asarray(heads).tolist(), wait))
    raise AssertionError("unreachable")  # the loop returns on its last attempt


def _follow_links(
    here: np.ndarray, wanted: np.ndarray, occupant: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For a joint step: which robots move, which follow another into the cell it
    leaves, and whom each follows (itself if nobody)."""
    robots = np.arange(len(here))
    occupant[here] = robots
    ahead = occupant[wanted]
    occupant[here] = NO_ROBOT
    moving = wanted != here
    follows = moving & (ahead != NO_ROBOT) & (ahead != robots)
    return moving, follows, np.where(follows, ahead, robots)


def rotation_heads(here: np.ndarray, wanted: np.ndarray, occupant: np.ndarray) -> np.ndarray:
    """The lowest-numbered robot of each rotation of a joint step (sorted)."""
    _, follows, link = _follow_links(here, wanted, occupant)
    rotating = and_along(link, follows)
    if not rotating.any():
        return np.zeros(0, dtype=np.int64)
    least = np.arange(len(here))
    for _ in range(max(1, len(here)).bit_length() + 1):  # round every cycle by doubling
        least = np.minimum(least, least[link])
        link = link[link]
    return np.flatnonzero(rotating & (least == np.arange(len(here))))


def held_back(
    here: np.ndarray, wanted: np.ndarray, occupant: np.ndarray, hold: np.ndarray
) -> np.ndarray:
    """A joint step (cell indices ``here`` to ``wanted``, conflict-free) with the robots
    ``hold`` (``(N,)`` bool) kept where they are, and every robot that would enter the
    cell of one kept, down its chain; the rest unchanged, so the step stays conflict-free.
    ``occupant`` as :func:`without_rotations`'s. O(N log N)."""
    moving, _, link = _follow_links(here, wanted, occupant)
    keeps_moving = and_along(link, moving & ~np.asarray(hold, dtype=bool))
    return np.where(keeps_moving, wanted, here)


def without_rotations(here: np.ndarray, wanted: np.ndarray, occupant: np.ndarray) -> np.ndarray:
    """A joint step (cell indices ``here`` to ``wanted``, conflict-free) with every
    rotation held: the robots of a closed chain (each entering the cell the next one
    leaves) stay, and so does every robot entering the cell of one that stays, down its
    chain. The rest is unchanged, so the step stays conflict-free. ``occupant`` is a
    scratch array of one ``NO_ROBOT`` a cell (left as it was found). O(N log N)."""
    moving, follows, link = _follow_links(here, wanted, occupant)
    rotating = and_along(link, follows)  # every robot down its chain follows: a cycle
    if not rotating.any():
        return wanted
    keeps_moving = and_along(link, moving & ~rotating)
    return np.where(keeps_moving, wanted, here)
