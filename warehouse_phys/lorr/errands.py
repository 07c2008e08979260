"""Errands from a list: which location each robot of a fleet heads for next, as the
League of Robot Runners (LoRR) hands out an instance's tasks.

A task is a sequence of *errands* (stops), visited in order; a robot *finishes an
errand* on the step it ends on the errand's location, and a task when it has
finished its last errand (a 2023 task has one errand, so both counts agree there).
One errand counts per robot and step, as in the competition: a robot whose next
errand is where it stands finishes it on its next step if it stays. Three ways to
hand out the tasks, one class each, all with the same interface
(:class:`ErrandList`):

- :class:`RoundRobinErrands` (2023 ``"roundrobin"``): robot ``i``'s ``k``-th task is
  task ``(i + k N) mod T`` of the file; each robot always has one.
- :class:`GreedyErrands` (2023 ``"greedy"``): robots that are free, in robot order,
  take the next tasks of the file; once the file is used up, robots stay free.
- :class:`ScheduledTasks` (2024 and later): ``numTasksReveal x N`` tasks are open at a
  time; a finished task is replaced at once by the next in the file (cyclically); which
  free robot takes which open task is a *scheduler*'s choice
  (:mod:`warehouse_phys.lorr.scheduling`); a task's robot keeps it to its end.

:meth:`ErrandList.step` is O(N) array operations (the scheduler's own cost comes on
top: O(F log T) for the nearest pairing, F free robots and T open tasks, and a
matching over the free and re-paired robots for the default). Task ids are
the competition's: in 2023 ``"roundrobin"`` the order in which tasks are handed out,
otherwise the order in which they are revealed (the task of file line ``id mod T``).
With ``record=True`` the list keeps the events that the competition's output file
lists (assignments, finished errands, the tasks revealed); they cost O(events).
Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk
nor pygame.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from warehouse_phys.lorr.instances import SCHEDULED, LorrInstance
from warehouse_phys.lorr.rematching import rematch_candidates
from warehouse_phys.lorr.scheduling import Scheduler, schedule_checked, takes_task_lengths
from warehouse_phys.lorr.scheduling_assignment import default_scheduler
from warehouse_phys.lorr.station_cap import offered_within_cap

#: The goal of a robot without an errand.
NO_ERRAND = -1


@dataclass
class ErrandEvents:
    """What an errand list did, as the competition's output file reports it.

    ``assigned``: ``(step, robot, task)`` each time a robot is given a task;
    ``finished``: ``(step, robot, task, errands done)`` each time a robot finishes an
    errand (the count reaches the task's length when the task is finished);
    ``revealed``: ``(task, step, file line)`` each time a task is revealed (handed out,
    in 2023).
    """

    assigned: list[tuple[int, int, int]] = field(default_factory=list)
    finished: list[tuple[int, int, int, int]] = field(default_factory=list)
    revealed: list[tuple[int, int, int]] = field(default_factory=list)


class ErrandList:
    """Errands handed out from a LoRR instance's task list to a fleet of ``N`` robots.

    :attr:`goals` is each robot's next errand (a cell index, :data:`NO_ERRAND` for a
    free robot). :meth:`reset` hands out the first tasks (robots at their starts);
    :meth:`step` takes which robots ended the step on their goal and where every robot
    stands, counts their errands and tasks, and hands out the next. :attr:`errands_done`
    and :attr:`tasks_done` count since the reset (:attr:`errands_per_robot` and
    :attr:`tasks_per_robot` robot by robot); :attr:`events` is kept with ``record=True``.
    """

    def __init__(self, instance: LorrInstance, *, record: bool = False) -> None:
        self.instance = instance
        self.record = record
        n = instance.team_size
        #: Each robot's next errand (a cell index), :data:`NO_ERRAND` for a free robot.
        self.goals = np.full(n, NO_ERRAND, dtype=np.int64)
        #: Each robot's task id, -1 for a free robot, and the task's line in the file.
        self.tasks = np.full(n, -1, dtype=np.int64)
        self.lines = np.full(n, -1, dtype=np.int64)
        #: Errands each robot has finished of its task.
        self.progress = np.zeros(n, dtype=np.int64)
        self.errands_per_robot = np.zeros(n, dtype=np.int64)
        self.tasks_per_robot = np.zeros(n, dtype=np.int64)
        self.events = ErrandEvents()
        #: Steps since the reset.
        self.steps = 0

    @property
    def errands_done(self) -> int:
        """Errands finished since the reset (every robot's)."""
        return int(self.errands_per_robot.sum())

    @property
    def tasks_done(self) -> int:
        """Tasks finished since the reset: LoRR's ``numTaskFinished``."""
        return int(self.tasks_per_robot.sum())

    def reset(self, here: np.ndarray) -> None:
        """Start again: no errand done, the first tasks handed out (robots on ``here``)."""
        for array in (self.goals, self.tasks, self.lines):
            array[:] = -1
        for array in (self.progress, self.errands_per_robot, self.tasks_per_robot):
            array[:] = 0
        self.events = ErrandEvents()
        self.steps = 0
        self._restart()
        self._hand_out(np.asarray(here, dtype=np.int64))

    def step(self, arrived: np.ndarray, here: np.ndarray) -> np.ndarray:
        """One step: ``arrived`` (robot numbers) ended it on their goal, every robot stands
        on ``here``; returns the robots whose task is finished, then hands out tasks."""
        self.steps += 1
        arrived = np.asarray(arrived, dtype=np.int64)
        finished = arrived[:0]
        if arrived.size:
            self.progress[arrived] += 1
            self.errands_per_robot[arrived] += 1
            done = self.progress[arrived] >= self.instance.stops_per_task[self.lines[arrived]]
            if self.record:
                rows = zip(arrived.tolist(), self.tasks[arrived].tolist(),
                           self.progress[arrived].tolist(), strict=True)  # fmt: skip
                self.events.finished += [(self.steps, r, t, k) for r, t, k in rows]
            finished, going = arrived[done], arrived[~done]
            self.tasks_per_robot[finished] += 1
            self.goals[going] = self.instance.task_stops[
                self.instance.task_offsets[self.lines[going]] + self.progress[going]
            ]
            self._release(finished)
            self.goals[finished] = NO_ERRAND
            self.tasks[finished] = self.lines[finished] = -1
        self._hand_out(np.asarray(here, dtype=np.int64))
        return finished

    # -------------------------------------------------------- for the subclasses
    def _restart(self) -> None:
        """Forget what was handed out (at a reset)."""

    def _release(self, finished: np.ndarray) -> None:
        """The robots ``finished`` have finished their tasks (still held)."""

    def _hand_out(self, here: np.ndarray) -> None:
        """Give tasks to free robots, standing on ``here``."""
        raise NotImplementedError

    def _give(self, robots: np.ndarray, ids: np.ndarray, lines: np.ndarray) -> None:
        """Hand the tasks ``ids`` (file lines ``lines``) to ``robots``; each robot's goal
        is its task's first errand."""
        self.tasks[robots] = ids
        self.lines[robots] = lines
        self.progress[robots] = 0
        self.goals[robots] = self.instance.task_stops[self.instance.task_offsets[lines]]
        if self.record:
            self.events.assigned += [
                (self.steps, r, t) for r, t in zip(robots.tolist(), ids.tolist(), strict=True)
            ]

    def _reveal(self, ids: np.ndarray, lines: np.ndarray) -> None:
        if self.record:
            self.events.revealed += [
                (t, self.steps, line) for t, line in zip(ids.tolist(), lines.tolist(), strict=True)
            ]


class RoundRobinErrands(ErrandList):
    """LoRR 2023 ``"roundrobin"``: robot ``i``'s ``k``-th task is line ``(i + k N) mod T``
    of the task file; task ids count the tasks handed out (robots in order each step)."""

    def _restart(self) -> None:
        self._handed = np.zeros(len(self.goals), dtype=np.int64)
        self._next_id = 0

    def _hand_out(self, here: np.ndarray) -> None:
        free = np.flatnonzero(self.tasks < 0)
        if not free.size:
            return
        lines = (free + self._handed[free] * len(self.goals)) % self.instance.num_tasks
        self._handed[free] += 1
        ids = self._next_id + np.arange(len(free))
        self._next_id += len(free)
        self._reveal(ids, lines)
        self._give(free, ids, lines)


class GreedyErrands(ErrandList):
    """LoRR 2023 ``"greedy"``: free robots, in robot order, take the next lines of the task
    file (task id = line); once every line is handed out, robots stay free."""

    def _restart(self) -> None:
        self._next_line = 0

    def _hand_out(self, here: np.ndarray) -> None:
        free = np.flatnonzero(self.tasks < 0)
        count = min(len(free), self.instance.num_tasks - self._next_line)
        if count <= 0:
            return
        lines = self._next_line + np.arange(count)
        self._next_line += count
        self._reveal(lines, lines)
        self._give(free[:count], lines, lines)


class ScheduledTasks(ErrandList):
    """LoRR 2024 and later: ``numTasksReveal x N`` tasks open, refilled from the file in
    order (task ``id`` is line ``id mod T``) as tasks finish; a *scheduler* gives open
    tasks to free robots after every step (and at the reset), and a robot keeps its task
    to its end once it has finished the task's first errand (before that, the default
    scheduler may pair it again: below).

    ``scheduler`` (default: rematching,
    :func:`~warehouse_phys.lorr.scheduling_assignment.default_scheduler`) is any
    :data:`~warehouse_phys.lorr.scheduling.Scheduler`; what it returns is checked (each
    open task to one robot at most), and a bad answer raises ``ValueError``.

    A scheduler whose ``rematch`` is true (``"rematch"``,
    :class:`~warehouse_phys.lorr.scheduling_assignment.AssignmentScheduler`) also gets,
    each step, the robots on their way to a task not opened yet that
    :func:`~warehouse_phys.lorr.rematching.rematch_candidates` picks, their tasks back
    among the open ones: a robot may change its task before its first errand (as
    LoRR's start kit allows), and one the pairing leaves out keeps its own when no
    other robot took it. Over 2024 WAREHOUSE's first 2,000 steps (10,000 turning robots,
    guided PIBT, seed 0) it finished 21.33 tasks a step against the assignment's 20.45,
    and on the 2024 main round's random floors 5-26 % more than the nearest pairing
    (``docs/lorr.md``), so it is the default.

    A scheduler with a ``station_cap`` (``"rematch-capped"``; ``"rematch-backlog"``, the
    cap growing with a stop's backlog) is offered only the open tasks that
    :func:`~warehouse_phys.lorr.station_cap.offered_within_cap` lets through: no hand-out
    sends a first stop past its cap of robots on their way to it (robots paired again
    count as on their way, and their own tasks stay offered), and a free robot for which
    no task is offered waits, without a task, for room.
    """

    def __init__(
        self, instance: LorrInstance, *, scheduler: Scheduler | None = None, record: bool = False
    ) -> None:
        super().__init__(instance, record=record)
        self.scheduler = default_scheduler(instance.grid) if scheduler is None else scheduler
        open_tasks = instance.open_tasks
        #: The id of the task in each slot of the open tasks, and its robot (-1: none).
        self.open_ids = np.zeros(open_tasks, dtype=np.int64)
        self.open_robots = np.full(open_tasks, -1, dtype=np.int64)
        #: Each robot's slot among the open tasks, -1 for a free robot.
        self._slot = np.full(instance.team_size, -1, dtype=np.int64)
        #: Each task line's length from its first stop to its last [moves, Manhattan],
        #: for a scheduler that weighs it (``task_lengths``), else None.
        self._lengths = task_lengths(instance) if takes_task_lengths(self.scheduler) else None

    def _restart(self) -> None:
        self.open_ids[:] = np.arange(len(self.open_ids))
        self.open_robots[:] = -1
        self._slot[:] = -1
        self._next_id = len(self.open_ids)
        self._reveal(self.open_ids, self.open_ids % self.instance.num_tasks)

    def _release(self, finished: np.ndarray) -> None:
        """Each finished task's slot takes the next task of the file."""
        slots = self._slot[finished]
        fresh = self._next_id + np.arange(len(slots))
        self._next_id += len(slots)
        self.open_ids[slots] = fresh
        self.open_robots[slots] = -1
        self._slot[finished] = -1
        self._reveal(fresh, fresh % self.instance.num_tasks)

    def _hand_out(self, here: np.ndarray) -> None:
        again, their_slots = self._rematched(here)
        free = np.flatnonzero(self._slot < 0)
        slots = np.flatnonzero(self.open_robots < 0)
        lines = self.open_ids[slots] % self.instance.num_tasks
        firsts = self.instance.task_stops[self.instance.task_offsets[lines]]
        cap = getattr(self.scheduler, "station_cap", None)
        if cap is not None and slots.size:
            # Robots paired again count as on their way, and their own tasks stay offered:
            # each may keep its task without taking another robot's room.
            going = np.flatnonzero((self._slot >= 0) & (self.progress == 0))
            offered = offered_within_cap(
                firsts, self.goals[np.concatenate([going, again])], cap,
                held=np.isin(slots, their_slots),
                backlog=getattr(self.scheduler, "cap_follows_backlog", False))  # fmt: skip
            slots, lines, firsts = slots[offered], lines[offered], firsts[offered]
        if not free.size or not slots.size:
            if again.size:
                self._keep_or_free(again, their_slots)
            return
        lengths = None if self._lengths is None else self._lengths[lines]
        chosen = schedule_checked(self.scheduler, here[free], firsts, self.instance.grid.cols,
                                  lengths)  # fmt: skip
        taking = chosen >= 0
        robots, slots = free[taking], slots[chosen[taking]]
        self._slot[robots] = slots
        self.open_robots[slots] = robots
        if again.size:  # a robot paired again with its own task keeps it as it was
            before = np.full(len(self._slot), -1, dtype=np.int64)
            before[again] = their_slots
            new = self._slot[robots] != before[robots]
            robots, slots = robots[new], slots[new]
            self._keep_or_free(again, their_slots)
        self._give(robots, self.open_ids[slots], self.open_ids[slots] % self.instance.num_tasks)

    def _rematched(self, here: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For a rematching scheduler (the class docstring): the robots on their way to a
        task not opened yet that go back into the pairing, freed with their tasks, and
        the slots their tasks hold; none otherwise."""
        none = np.zeros(0, dtype=np.int64)
        if not getattr(self.scheduler, "rematch", False):
            return none, none
        going = np.flatnonzero((self._slot >= 0) & (self.progress == 0))
        picked = going[rematch_candidates(here[going], self.goals[going],
                                          self.instance.grid.cols,
                                          getattr(self.scheduler, "distances", None))]  # fmt: skip
        their_slots = self._slot[picked].copy()
        self.open_robots[their_slots] = -1
        self._slot[picked] = -1
        return picked, their_slots

    def _keep_or_free(self, again: np.ndarray, their_slots: np.ndarray) -> None:
        """Robots paired again whom the pairing left without a task: each keeps its own if
        no other robot took it, else it is free."""
        left = self._slot[again] < 0
        robots, slots = again[left], their_slots[left]
        keep = self.open_robots[slots] < 0
        self._slot[robots[keep]] = slots[keep]
        self.open_robots[slots[keep]] = robots[keep]
        lost = robots[~keep]
        self.goals[lost] = NO_ERRAND
        self.tasks[lost] = self.lines[lost] = -1


def task_lengths(instance: LorrInstance) -> np.ndarray:
    """``(tasks,)`` int64: each task's length from its first stop to its last, the
    Manhattan distances between its consecutive stops summed [moves]."""
    stops, cols = instance.task_stops, instance.grid.cols
    rows, columns = np.divmod(stops, cols)
    legs = np.abs(np.diff(rows)) + np.abs(np.diff(columns))
    # A leg joins two stops of one task unless the second is a task's first stop.
    within = np.ones(len(legs), dtype=bool)
    firsts = instance.task_offsets[1:-1]
    within[firsts[firsts > 0] - 1] = False
    totals = np.concatenate([[0], np.cumsum(np.where(within, legs, 0))])
    return totals[instance.task_offsets[1:] - 1] - totals[instance.task_offsets[:-1]]


def errand_list(
    instance: LorrInstance, *, scheduler: Scheduler | None = None, record: bool = False
) -> ErrandList:
    """The errand list of ``instance``'s assignment (see the module)."""
    if instance.assignment == SCHEDULED:
        return ScheduledTasks(instance, scheduler=scheduler, record=record)
    if scheduler is not None:
        raise ValueError(
            f"{instance.name} assigns its tasks {instance.assignment!r} (LoRR 2023): "
            "a scheduler takes no part; pass scheduler=None"
        )
    if instance.assignment == "greedy":
        return GreedyErrands(instance, record=record)
    return RoundRobinErrands(instance, record=record)
