"""A cap on each station's queue: at most so many robots on their way to one first stop.

On a floor whose tasks all begin at a few hundred pick-up stations (2024 WAREHOUSE: 352
stations for 10,000 robots), a scheduler that pairs each robot with the tasks nearest it
sends many robots to one station at once: at step 400 of a run, 7.9 robots on their way
to a station on average, 16 or more to a tenth of them, 33 to the busiest; the robots
queueing in the stations' pockets (dead ends three cells deep) stood still two thirds of
the time. :func:`offered_within_cap` keeps a pairing from sending more than ``cap``
robots to one first stop: a task whose first stop already has ``cap`` robots on their
way is not offered (a robot then takes a task at another station, or waits for room),
save to a robot paired again (:mod:`~warehouse_phys.lorr.rematching`), whose own task
stays offered to the pairing. On WAREHOUSE a cap of 8 made 23.98 tasks a step over 5,000
steps against 21.90 without (``docs/lorr.md``). On a floor whose tasks begin anywhere
(the 2024 random and city floors) a stop rarely has that many robots on their way: on
RANDOM-05 and CITY-02 the cap changed nothing in the steps measured.

A fixed cap lets a station's open tasks pile up when robots come free far from it: in
the capped scheduler's congestion-free flow on WAREHOUSE, the 72 side stations' share of
the open tasks grew from a fifth to nearly two fifths by step 1,250 while robots waited
for room elsewhere (``docs/lorr.md``). With ``backlog=True`` each stop's cap follows its
backlog (:func:`stop_caps`): a stop with more of the tasks on offer to the pairing than
the mean of the stops that have any may have that many times the cap of robots on its
way (the tasks on offer: the open tasks no robot has, and those of the robots paired
again, at most :data:`~warehouse_phys.lorr.rematching.REMATCH_MAX`). In that flow the
side stations' open tasks then stayed level and no robot waited for room.

:class:`~warehouse_phys.lorr.scheduling_assignment.AssignmentScheduler`'s
``station_cap`` (``"rematch-capped"`` by name; with ``cap_follows_backlog``,
``"rematch-backlog"``) asks the fleet's errand list
(:class:`~warehouse_phys.lorr.errands.ScheduledTasks`) to offer its pairing only these
tasks; the start-kit entry's ``"assignment-capped"`` and ``"assignment-backlog"``
(:class:`~warehouse_phys.lorr.startkit.scheduler.EntryScheduler`) do the same. Like
:mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import numpy as np

#: Robots on their way to one first stop at most for ``"rematch-capped"`` (and the least
#: cap of a stop for ``"rematch-backlog"``): on 2024
#: WAREHOUSE (``docs/lorr.md``) the mean station had 5-8 robots on their way to it. The
#: only value measured.
STATION_CAP = 8


def check_cap(cap: int) -> int:
    """``cap`` as an int, checked.

    Raises:
        ValueError: for a ``cap`` that is not an int of at least 1.
    """
    if isinstance(cap, bool) or not isinstance(cap, int | np.integer) or cap < 1:
        raise ValueError(f"cap must be an int >= 1, got {cap!r}")
    return int(cap)


def station_loads(stops: np.ndarray, goals: np.ndarray) -> np.ndarray:
    """``(len(stops),)`` int64: how many of ``goals`` (the cells robots are on their way
    to) equal each of ``stops`` (cell indices). Memory grows with the robots, not the
    floor's cells."""
    stops = np.asarray(stops, dtype=np.int64)
    cells, counts = np.unique(np.asarray(goals, dtype=np.int64), return_counts=True)
    if not cells.size:
        return np.zeros(len(stops), dtype=np.int64)
    at = np.minimum(np.searchsorted(cells, stops), cells.size - 1)
    return np.where(cells[at] == stops, counts[at], 0).astype(np.int64)


def stop_caps(stops: np.ndarray, cap: int) -> np.ndarray:
    """``(len(stops),)`` int64: the cap of each task's stop when the cap follows the
    backlog: ``max(cap, ceil(cap * n / mean))``, where ``n`` is how many of ``stops``
    (the first stops of the tasks on offer, cell indices) are that stop and ``mean`` is
    ``n``'s mean over the distinct stops. Computed in whole numbers, so a stop with exactly the
    mean has ``cap``; a stop with twice the mean, ``2 * cap``.

    Raises:
        ValueError: for a ``cap`` that is not an int of at least 1.
    """
    cap = check_cap(cap)
    stops = np.asarray(stops, dtype=np.int64)
    if not stops.size:
        return np.zeros(0, dtype=np.int64)
    _, inverse, counts = np.unique(stops, return_inverse=True, return_counts=True)
    # cap * n / (len(stops) / distinct), rounded up: -(-a // b) is ceil(a / b) for b > 0.
    backlog = -(-cap * counts * len(counts) // len(stops))
    return np.maximum(cap, backlog)[inverse.reshape(-1)].astype(np.int64)


def offered_within_cap(
    stops: np.ndarray,
    goals: np.ndarray,
    cap: int,
    held: np.ndarray | None = None,
    *,
    backlog: bool = False,
) -> np.ndarray:
    """Which open tasks a pairing may be offered, ``(len(stops),)`` bool: the tasks'
    first stops are ``stops``, in the open-task list's order, and ``goals`` are the first
    stops robots are already on their way to. Every task ``held`` (``(len(stops),)``
    bool: a robot paired again holds it, and is among ``goals``), and at each stop the
    first of the others up to the stop's cap less the robots on their way to it (none if
    that is not positive), so that however the pairing pairs, a stop with at most its
    cap of robots on their way has at most its cap after it. The stop's cap is ``cap``,
    or with ``backlog`` its :func:`stop_caps` (counted over all of ``stops``, held
    tasks included).

    Raises:
        ValueError: for a ``cap`` that is not an int of at least 1, or ``held`` of
            another shape than ``stops``.
    """
    check_cap(cap)
    stops = np.asarray(stops, dtype=np.int64)
    held = np.zeros(len(stops), dtype=bool) if held is None else np.asarray(held, dtype=bool)
    if held.shape != stops.shape:
        raise ValueError(f"held must be one bool a task ({stops.shape}), got {held.shape}")
    others = np.flatnonzero(~held)
    order = others[np.argsort(stops[others], kind="stable")]
    sorted_stops = stops[order]
    # A task's rank among the others at its stop, in list order.
    rank = np.arange(len(order)) - np.searchsorted(sorted_stops, sorted_stops, side="left")
    caps = stop_caps(stops, cap)[order] if backlog else cap
    room = caps - station_loads(sorted_stops, goals)
    offered = held.copy()
    offered[order] = rank < room
    return offered
