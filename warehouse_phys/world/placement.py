"""Where a fleet's robots start and where their packages appear: the fleet's placement rules.

Pure functions of a floor, a fleet's size and a numpy generator, with cells as indices
``row * cols + col`` (:class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv` composes
them):

- :func:`layout_starts`: the starts of ``starts="layout"``: a fleet layout's ``S`` cells,
  else the floor's start and the next reachable cells in reading order;
- :func:`check_room`: refuses a fleet the floor has no start or package cells for,
  with the counts;
- :func:`draw_placement`: the robots' cells and first packages at a reset;
- :func:`draw_new_packages`: new packages for robots that delivered (lifelong), each
  uniform over the package cells that no robot and no other package holds.

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.world.grid import WarehouseGrid

#: How a fleet's robots start: ``"layout"`` cells, ``"random"`` draws, or ``"auto"``.
START_MODES = ("auto", "layout", "random")
#: Rejection draws a new package tries before an exact draw among the free cells.
_REJECTION_TRIES = 8


def package_cells(grid: WarehouseGrid) -> np.ndarray:
    """The floor's package cells as indices, in row-major order (a fresh array)."""
    return np.array(grid.target_indices, np.int64)


def reachable_cells(grid: WarehouseGrid) -> np.ndarray:
    """The cells a robot can reach from the floor's start, as sorted indices."""
    return np.flatnonzero(grid.reachable_mask).astype(np.int64, copy=False)


def layout_starts(grid: WarehouseGrid, n: int, reachable: np.ndarray) -> np.ndarray:
    """``starts="layout"``: a fleet layout's ``S`` cells (several marked); otherwise the
    floor's start, then the other cells robots can reach in reading order; ``(n,)``.

    Raises:
        ValueError: if the floor has fewer such cells than robots, with the counts.
    """
    marked = grid.starts
    if len(marked) > 1:
        if len(marked) < n:
            raise ValueError(
                f"{n} robots need {n} start cells; the layout marks {len(marked)} ('S')"
            )
        return np.array(marked[:n], dtype=np.int64).reshape(n, 2) @ np.array([grid.cols, 1])
    start = grid.start[0] * grid.cols + grid.start[1]
    others = reachable[reachable != start]
    if len(others) + 1 < n:
        raise ValueError(
            f"{n} robots need {n} start cells; this floor has {len(others) + 1} cells a "
            "robot can reach"
        )
    return np.concatenate([[start], others[: n - 1]]).astype(np.int64)


def check_room(
    n: int,
    starts_mode: str,
    lifelong: bool,
    targets: np.ndarray,
    reachable: np.ndarray,
    starts: np.ndarray | None,
) -> None:
    """Refuse a fleet of ``n`` robots the floor has no room for, with the counts.

    ``starts`` are the layout starts (``starts_mode="layout"``), ``targets`` the package
    cells and ``reachable`` the cells robots reach, as indices.

    Raises:
        ValueError: naming what is short: cells to start on off the packages, package
            cells (one per robot; lifelong, one per robot and per package).
    """
    if starts_mode != "layout" and len(reachable) < 2 * n:
        raise ValueError(
            f"{n:,} robots need {2 * n:,} cells a robot can reach (random starts, off the "
            f"packages); this floor has {len(reachable):,}"
        )
    if lifelong:
        # A robot that delivers stands on a package cell, the others may too, and
        # their packages take n - 1 more: its new one needs one cell beyond.
        needed, room = 2 * n, len(targets)
        where = " (lifelong: one for every robot and every package)"
    elif starts_mode == "layout":
        needed = n
        room = int((~np.isin(targets, starts)).sum())
        where = " away from the starts"
    else:  # random starts stand off the packages
        needed, room, where = n, len(targets), ""
    if room < needed:
        raise ValueError(
            f"{n:,} robots need {needed:,} package cells{where}; this floor has {room:,}"
        )


def draw_placement(
    rng: np.random.Generator,
    n: int,
    targets: np.ndarray,
    reachable: np.ndarray,
    starts: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray]:
    """The robots' cells and their packages at a reset, ``(n,)`` indices each: with
    ``starts`` (layout starts) the robots stand there and the packages are drawn off them;
    otherwise the packages are drawn first, then the starts uniformly among the reachable
    cells off them; all distinct."""
    if starts is None:  # the packages first, then the starts off them
        packages = targets[rng.choice(len(targets), n, replace=False)]
        allowed = reachable[~np.isin(reachable, packages)]
        here = allowed[rng.choice(len(allowed), n, replace=False)]
    else:
        here = starts
        allowed = targets[~np.isin(targets, here)]
        packages = allowed[rng.choice(len(allowed), n, replace=False)]
    return here, packages


def draw_new_packages(
    rng: np.random.Generator,
    targets: np.ndarray,
    cells: int,
    here: np.ndarray,
    packages: np.ndarray,
    robots: np.ndarray,
) -> np.ndarray:
    """New packages for ``robots`` (the others keep ``packages``), each uniform over the
    package cells ``targets`` on no robot (``here``) and no other robot's package;
    returns the new ones, in the order of ``robots``. ``cells``: the floor's cell count.

    The robots draw in order, each one cell at a time (rejection sampling, then an exact
    draw among the free cells if it keeps missing). All first draws are made at once;
    when they all land on free, distinct cells (the usual case) that is what drawing in
    turn gives, else the generator is put back and the robots draw in turn.
    """
    taken = np.zeros(cells, dtype=bool)
    taken[here] = True
    keep = np.ones(len(packages), dtype=bool)
    keep[robots] = False
    taken[packages[keep]] = True
    before = rng.bit_generator.state
    drawn = targets[rng.integers(len(targets), size=robots.size)]
    if not taken[drawn].any() and (robots.size == 1 or np.unique(drawn).size == robots.size):
        return drawn
    rng.bit_generator.state = before
    drawn = np.empty(robots.size, dtype=np.int64)
    for position in range(robots.size):
        for _ in range(_REJECTION_TRIES):
            cell = targets[rng.integers(len(targets))]
            if not taken[cell]:
                break
        else:
            free = targets[~taken[targets]]
            cell = free[rng.integers(len(free))]
        taken[cell] = True
        drawn[position] = cell
    return drawn
