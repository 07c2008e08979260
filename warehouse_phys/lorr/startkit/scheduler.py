"""The entry's scheduler: which free robot takes which open task, by the package's schedulers.

The start kit asks its scheduler for a whole schedule, one task (or -1) a robot, from the
open tasks (``task_pool``), the current schedule and the robots' predicted states. A robot
keeps an opened task (an errand of it done: the kit refuses to take it from its robot);
a task not opened yet may go to another robot, so each round the robots on their way to
one go back into the pairing with the free robots, and the tasks nobody has or is on
the way to are paired with them by one of :data:`ENTRY_SCHEDULERS`: ``"assignment"``
(the entry's: a minimum-cost matching on distances round the shelves,
:class:`~warehouse_phys.lorr.scheduling_assignment.AssignmentScheduler`),
``"assignment-capped"`` (the same, offered no task whose first stop already has
:data:`~warehouse_phys.lorr.station_cap.STATION_CAP` robots on their way: the fleet's
``"rematch-capped"``, :mod:`warehouse_phys.lorr.station_cap`), ``"assignment-backlog"``
(the same cap, growing at a stop with more open tasks than the mean stop: the fleet's
``"rematch-backlog"``), ``"makespan"``
(the least Manhattan distance to the first errand plus the task's own length, as the
kit's default entry weighs them) or ``"nearest"``. Like :mod:`warehouse_phys.world.grid`, this
module imports neither gymnasium, pymunk nor pygame.

Why pair again: :mod:`warehouse_phys.lorr.rematching`, which picks the robots. By the
kit's rules (:mod:`~warehouse_phys.lorr.startkit.system`, 600 ticks, delay seeds 0-11)
pairing again lifted random-example_400 from 507.7 tasks to 522.3 (guided PIBT, the
assignment scheduler), with no schedule error.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from warehouse_phys.lorr.rematching import rematch_candidates
from warehouse_phys.lorr.scheduling import SCHEDULERS, schedule_checked, scheduler_named
from warehouse_phys.lorr.scheduling_assignment import AssignmentScheduler
from warehouse_phys.lorr.station_cap import STATION_CAP, offered_within_cap
from warehouse_phys.world.grid import WarehouseGrid

#: The schedulers an entry may use, by name: the built-in greedy pairings, and the
#: minimum-cost assignment on true distances (which needs the floor), without and with
#: a cap on each station's queue, fixed or following the station's backlog.
ENTRY_SCHEDULERS = (*SCHEDULERS, "assignment", "assignment-capped", "assignment-backlog")
#: The fleet's name (``simulate --scheduler``) of each entry scheduler, which ``simulate``
#: plays by the kit's rules: the entry's assignments always pair again.
FLEET_SCHEDULERS = {**{name: name for name in SCHEDULERS}, "assignment": "rematch",
                    "assignment-capped": "rematch-capped",
                    "assignment-backlog": "rematch-backlog"}  # fmt: skip


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

    With ``"assignment-capped"`` the pairing is offered only the tasks that
    :func:`~warehouse_phys.lorr.station_cap.offered_within_cap` lets through, counting as
    on their way to a first stop the robots ``unopened`` (those paired again too, whose
    own tasks stay offered), the free robots proposed for their held tasks and the tasks
    still held: no first stop then has more than the cap of robots on their way to it
    (the fleet's ``"rematch-capped"``), unless it had before. With
    ``"assignment-backlog"`` each stop's cap follows its backlog
    (:func:`~warehouse_phys.lorr.station_cap.stop_caps`, the fleet's
    ``"rematch-backlog"``).

    Args:
        cols: The floor's width (cells are ``row * cols + col``).
        scheduler: A name of :data:`ENTRY_SCHEDULERS`.
        grid: The floor, which ``"assignment"``, ``"assignment-capped"`` and
            ``"assignment-backlog"`` measure their distances on.
        pair_again: Pair the robots on their way to a task not opened again each round
            (the module), when :meth:`schedule` is told which they are.

    Raises:
        ValueError: for an unknown scheduler, or an assignment without the floor.
    """

    def __init__(
        self,
        cols: int,
        scheduler: str = "assignment",
        grid: WarehouseGrid | None = None,
        *,
        pair_again: bool = True,
    ) -> None:
        self.cols = int(cols)
        self.name = scheduler
        self.pair_again = bool(pair_again)
        if scheduler not in ENTRY_SCHEDULERS:
            raise ValueError(
                f"unknown scheduler {scheduler!r}; known: {', '.join(ENTRY_SCHEDULERS)}"
            )
        if scheduler not in SCHEDULERS:  # an assignment
            if grid is None:
                raise ValueError(f"the {scheduler} scheduler measures on the floor: give grid")
            cap = None if scheduler == "assignment" else STATION_CAP
            self.scheduler = AssignmentScheduler(
                grid, station_cap=cap, cap_follows_backlog=scheduler == "assignment-backlog"
            )
        else:
            self.scheduler = scheduler_named(scheduler)
        #: The most robots on their way to one first stop (None: no cap).
        self.station_cap: int | None = getattr(self.scheduler, "station_cap", None)
        #: The task held for each robot (-1: none).
        self.held = np.zeros(0, dtype=np.int64)

    def schedule(
        self,
        current: np.ndarray,
        cells: np.ndarray,
        tasks: OpenTasks,
        finishing: np.ndarray | None = None,
        unopened: np.ndarray | None = None,
    ) -> np.ndarray:
        """``(N,)`` int64: each robot's task id, -1 for none: ``current`` (``(N,)`` the
        kit's schedule) kept for every robot that has a task, a free robot proposed for
        the task held for it, and the other free robots, at ``cells`` (``(N,)`` their
        predicted cells), paired with the tasks of ``tasks`` that no robot has or holds;
        robots ``finishing`` (``(N,)`` bool) without a held task are paired too, and hold
        theirs. Robots ``unopened`` (``(N,)`` bool: a task of which no errand is done, nor
        will be by the end of their staged actions) are paired again with their tasks, as
        :func:`~warehouse_phys.lorr.rematching.rematch_candidates` picks them
        (:attr:`pair_again`); one the pairing leaves without a task keeps its own.

        Raises:
            ValueError: for ``"assignment-capped"`` or ``"assignment-backlog"`` without
                ``unopened`` (the cap counts the robots on their way to a first stop).
        """
        if self.station_cap is not None and unopened is None:
            raise ValueError(f"{self.name} counts the robots on their way to a first stop: "
                             "give unopened")  # fmt: skip
        proposal = np.asarray(current, dtype=np.int64).copy()
        n = len(proposal)
        cells = np.asarray(cells, np.int64)
        finishing = np.zeros(n, bool) if finishing is None else np.asarray(finishing, bool)
        if len(self.held) != n:
            self.held = np.full(n, -1, dtype=np.int64)
        ids, robot = np.asarray(tasks.ids, np.int64), np.asarray(tasks.robot, np.int64).copy()
        next_stop = np.asarray(tasks.next_stop, np.int64)
        again = np.zeros(n, bool)
        if unopened is not None and self.pair_again:
            again = self._again(proposal, cells, ids, next_stop,
                                np.asarray(unopened, bool) & ~finishing)  # fmt: skip
            robot[np.isin(ids, proposal[again])] = -1
            proposal[again] = -1
        free = proposal < 0
        still = np.isin(self.held, ids[robot < 0]) & (free | finishing)
        self.held[~still] = -1
        claim = free & (self.held >= 0)
        proposal[claim] = self.held[claim]
        self.held[claim] = -1
        seekers = np.flatnonzero((proposal < 0) | (finishing & (self.held < 0) & ~free))
        untaken = np.flatnonzero((robot < 0) & ~np.isin(ids, proposal) & ~np.isin(ids, self.held))
        if self.station_cap is not None and untaken.size:
            current = np.asarray(current, np.int64)
            going = np.concatenate([current[np.asarray(unopened, bool) & (current >= 0)],
                                    proposal[claim], self.held[self.held >= 0]])  # fmt: skip
            at, listed = _positions(ids, going)
            goals = next_stop[at[listed]]
            # A robot paired again counts as on its way, and its own task stays offered.
            offered = offered_within_cap(next_stop[untaken], goals, self.station_cap,
                                         held=np.isin(ids[untaken], current[again]),
                                         backlog=self.scheduler.cap_follows_backlog)  # fmt: skip
            untaken = untaken[offered]
        if seekers.size and untaken.size:
            lengths = np.asarray(tasks.length, np.int64)[untaken]
            chosen = schedule_checked(self.scheduler, cells[seekers], next_stop[untaken],
                                      self.cols, lengths)  # fmt: skip
            taking = chosen >= 0
            picked = ids[untaken[chosen[taking]]]
            robots = seekers[taking]
            now = proposal[robots] < 0
            proposal[robots[now]] = picked[now]
            self.held[robots[~now]] = picked[~now]
        left = np.flatnonzero(again & (proposal < 0))  # the pairing gave them none
        own = np.asarray(current, np.int64)[left]
        keep = ~np.isin(own, proposal) & ~np.isin(own, self.held)
        proposal[left[keep]] = own[keep]
        return proposal

    def _again(
        self, proposal: np.ndarray, cells: np.ndarray, ids: np.ndarray, next_stop: np.ndarray,
        unopened: np.ndarray,
    ) -> np.ndarray:  # fmt: skip
        """``(N,)`` bool: the robots of ``unopened`` with an open task that
        :func:`~warehouse_phys.lorr.rematching.rematch_candidates` picks (round the
        shelves for ``"assignment"``, else Manhattan)."""
        again = np.zeros(len(proposal), bool)
        if not len(ids):
            return again
        at, listed = _positions(ids, proposal)
        robots = np.flatnonzero(unopened & listed & (proposal >= 0))
        distances = getattr(self.scheduler, "distances", None)
        picked = rematch_candidates(cells[robots], next_stop[at[robots]], self.cols, distances)
        again[robots[picked]] = True
        return again


def _positions(ids: np.ndarray, wanted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where each of ``wanted`` (task ids) is in ``ids`` (the open tasks' ids, not empty),
    and whether it is there at all (``(len(wanted),)`` each; a position of a task not
    there is meaningless)."""
    order = np.argsort(ids, kind="stable")
    slot = np.minimum(np.searchsorted(ids[order], wanted), len(ids) - 1)
    return order[slot], ids[order[slot]] == wanted
