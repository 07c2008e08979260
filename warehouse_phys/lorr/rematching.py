"""Rematching: which robots on their way to a task not opened yet go back into the pairing.

In LoRR 2024 and later a task is *opened* once its robot finishes its first errand; until
then the task may go to another robot. Tasks are revealed as others finish, so a robot
half-way to a far task may now pass a new one close by, while a robot freed since
stands nearer the far one: pairing such robots again, with the free ones, shortens the
fleet's ways to its first errands. :func:`rematch_candidates` picks them: those more
than :data:`KEEP_WITHIN` moves from their first errand (a robot about to open its task
keeps it), at most :data:`REMATCH_MAX`, the farthest first (the pairing's cost grows
with the robots in it). The start-kit entry's scheduler
(:class:`~warehouse_phys.lorr.startkit.scheduler.EntryScheduler`) and the fleet's
errand list with a rematching scheduler
(:class:`~warehouse_phys.lorr.errands.ScheduledTasks`) both take them from here.

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.planners.distances import DistanceMaps

#: A robot this close to its task's first errand keeps the task [moves]: in the start kit
#: a schedule is taken a round after it is made, and the robot may have opened the task
#: by then (taking it away would be a schedule error). Over delay seeds 0-11 on
#: random-example_400 (the kit's rules, the entry's planner), 2 gave 537.4 tasks, 0 gave
#: 532.3 and 4 gave 528.8; with one-step guided PIBT (seeds 0-5), 2: 523.7, 4: 521.3,
#: 8: 514.0.
KEEP_WITHIN = 2
#: Most robots paired again at once, the farthest from their first errands first: the
#: pairing's cost grows with the robots in it, and the start kit gives the scheduler and
#: the planner one second together. In the kit at 10,000 robots (some 8,000 of them on
#: their way to a task), the entry's scheduler took 127 ms a call at the median without
#: rematching, 138 ms with this bound and 141 ms without it.
REMATCH_MAX = 1000


def rematch_candidates(
    cells: np.ndarray, first_stops: np.ndarray, cols: int, distances: DistanceMaps | None = None
) -> np.ndarray:
    """The positions of the robots at ``cells`` (``(R,)`` cell indices), each on its way
    to a task whose first errand is at ``first_stops`` (``(R,)``), to pair again: more
    than :data:`KEEP_WITHIN` moves from it (round the shelves by ``distances``, else
    Manhattan), at most :data:`REMATCH_MAX`, the farthest first (ties in order).

    Returns:
        ``(M,)`` int64 positions into ``cells``, in increasing order.
    """
    cells = np.asarray(cells, dtype=np.int64)
    first_stops = np.asarray(first_stops, dtype=np.int64)
    if distances is not None:
        way = distances.lookup(cells, first_stops)
    else:
        way = np.abs(cells // cols - first_stops // cols) + np.abs(
            cells % cols - first_stops % cols
        )
    far = np.flatnonzero(way > KEEP_WITHIN)
    if len(far) > REMATCH_MAX:
        far = np.sort(far[np.argsort(-way[far], kind="stable")[:REMATCH_MAX]])
    return far
