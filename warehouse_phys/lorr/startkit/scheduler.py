"""The entry's scheduler: which free robot takes which open task, by the package's schedulers.

The start kit asks its scheduler for a whole schedule, one task (or -1) a robot, from the
open tasks (``task_pool``), the current schedule and the robots' predicted states. A robot
keeps the task it has (the kit refuses to take an opened task from its robot, and a task
not yet opened gains nothing by moving); the free robots and the tasks nobody has are
paired by one of :data:`ENTRY_SCHEDULERS`: ``"assignment"`` (the entry's: a minimum-cost
matching on distances round the shelves,
:class:`~warehouse_phys.lorr.scheduling_assignment.AssignmentScheduler`), ``"makespan"``
(the least Manhattan distance to the first errand plus the task's own length, as the
kit's default entry weighs them) or ``"nearest"``. Like :mod:`warehouse_phys.world.grid`, this
module imports neither gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from warehouse_phys.lorr.scheduling import SCHEDULERS, schedule_checked, scheduler_named
from warehouse_phys.lorr.scheduling_assignment import AssignmentScheduler
from warehouse_phys.world.grid import WarehouseGrid

#: The schedulers an entry may use, by name: the built-in greedy pairings, and the
#: minimum-cost assignment on true distances (which needs the floor).
ENTRY_SCHEDULERS = (*SCHEDULERS, "assignment")


class OpenTasks(NamedTuple):
    """The kit's task pool as arrays, ``(K,)`` each, in the order the tasks were revealed."""

    #: Task ids.
    ids: np.ndarray
    #: Each task's next errand (a cell index).
    next_stop: np.ndarray
    #: Its length from that errand to its last [moves, Manhattan].
    length: np.ndarray
    #: The robot it is assigned to, -1 for none.
    robot: np.ndarray


class EntryScheduler:
    """The schedule the kit asks for (see the module), with tasks held for robots about to
    be free.

    A robot whose staged actions finish its task (``finishing``) is still busy for the
    kit, which frees it only at the next round, and a plan for it arrives a round after
    that. So the scheduler picks its next task now, among the tasks nobody has, and
    *holds* it (:attr:`held`): the planner plans towards it at once, no other robot is
    given it, and the robot is proposed for it at the next round, when the kit has freed
    it (if the task is still open then).

    Args:
        cols: The floor's width (cells are ``row * cols + col``).
        scheduler: A name of :data:`ENTRY_SCHEDULERS`.
        grid: The floor, which ``"assignment"`` measures its distances on.

    Raises:
        ValueError: for an unknown scheduler, or ``"assignment"`` without the floor.
    """

    def __init__(
        self, cols: int, scheduler: str = "assignment", grid: WarehouseGrid | None = None
    ) -> None:
        self.cols = int(cols)
        self.name = scheduler
        if scheduler == "assignment":
            if grid is None:
                raise ValueError("the assignment scheduler measures on the floor: give grid")
            self.scheduler = AssignmentScheduler(grid)
        else:
            self.scheduler = scheduler_named(scheduler)
        #: The task held for each robot (-1: none).
        self.held = np.zeros(0, dtype=np.int64)

    def schedule(
        self,
        current: np.ndarray,
        cells: np.ndarray,
        tasks: OpenTasks,
        finishing: np.ndarray | None = None,
    ) -> np.ndarray:
        """``(N,)`` int64: each robot's task id, -1 for none: ``current`` (``(N,)`` the
        kit's schedule) kept for every robot that has a task, a free robot proposed for
        the task held for it, and the other free robots, at ``cells`` (``(N,)`` their
        predicted cells), paired with the tasks of ``tasks`` that no robot has or holds;
        robots ``finishing`` (``(N,)`` bool) without a held task are paired too, and hold
        theirs."""
        proposal = np.asarray(current, dtype=np.int64).copy()
        n = len(proposal)
        finishing = np.zeros(n, bool) if finishing is None else np.asarray(finishing, bool)
        if len(self.held) != n:
            self.held = np.full(n, -1, dtype=np.int64)
        ids, robot = np.asarray(tasks.ids, np.int64), np.asarray(tasks.robot, np.int64)
        free = proposal < 0
        still = np.isin(self.held, ids[robot < 0]) & (free | finishing)
        self.held[~still] = -1
        claim = free & (self.held >= 0)
        proposal[claim] = self.held[claim]
        self.held[claim] = -1
        seekers = np.flatnonzero((proposal < 0) | (finishing & (self.held < 0) & ~free))
        untaken = np.flatnonzero((robot < 0) & ~np.isin(ids, proposal) & ~np.isin(ids, self.held))
        if not seekers.size or not untaken.size:
            return proposal
        chosen = schedule_checked(self.scheduler, np.asarray(cells, np.int64)[seekers],
                                  np.asarray(tasks.next_stop, np.int64)[untaken], self.cols,
                                  np.asarray(tasks.length, np.int64)[untaken])  # fmt: skip
        taking = chosen >= 0
        picked = ids[untaken[chosen[taking]]]
        robots = seekers[taking]
        now = proposal[robots] < 0
        proposal[robots[now]] = picked[now]
        self.held[robots[~now]] = picked[~now]
        return proposal
