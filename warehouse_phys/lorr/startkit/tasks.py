"""The start kit's task manager: open tasks, the schedules it takes at each round, the errands
it counts (League of Robot Runners 2026, ``src/TaskManager.cpp`` of the kit 3.1.0).

:class:`KitTasks` is :class:`~warehouse_phys.lorr.errands.ScheduledTasks` (the same open
tasks, ``numTasksReveal x N`` of them refilled from the file in order, the same errand
counting and events) with the kit's way of handing tasks out: nothing is handed out
between rounds; at each round :meth:`KitTasks.assign` takes the entry's proposed schedule
(one task id or -1 a robot) after the kit's checks, each a *schedule error* that leaves
the robot free or on its task:

1. a task that is no longer open (finished): the robot gets none;
2. a task proposed for two robots: the second gets none;
3. a robot whose task is opened (an errand of it done) proposed another: it keeps its own;
4. a task opened by another robot: the robot gets none.

A robot finishes an errand at the end of a tick on which it stands on it (the cell it is on
or is leaving: the kit's ``location``), one errand a robot a tick. The schedules are kept
as the kit writes them (``actualSchedule``: each change of a robot's task, -1 included,
at the round it takes effect; ``plannerSchedule``: each change of what the entry
proposed). Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium,
pymunk nor pygame.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.lorr.errands import NO_ERRAND, ScheduledTasks, task_lengths
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.lorr.startkit.scheduler import OpenTasks


class KitTasks(ScheduledTasks):
    """An instance's tasks handed out as the start kit does (see the module).

    Args:
        instance: A 2024 or later instance (tasks handed out by a scheduler).
        record: Keep the events, as :class:`~warehouse_phys.lorr.errands.ErrandList`.

    Raises:
        ValueError: for a 2023 instance (its tasks are not scheduled).
    """

    def __init__(self, instance: LorrInstance, *, record: bool = False) -> None:
        if instance.year < 2024:
            raise ValueError(f"{instance.name} is a 2023 instance: its tasks are not scheduled")
        super().__init__(instance, record=record)
        self._all_lengths = task_lengths(instance)
        n = instance.team_size
        #: ``[robot][(tick, task)]`` as the kit's ``actualSchedule`` and ``plannerSchedule``.
        self.actual_schedule: list[list[tuple[int, int]]] = [[] for _ in range(n)]
        self.planner_schedule: list[list[tuple[int, int]]] = [[] for _ in range(n)]
        #: ``[task, robot, other robot, tick, what]`` each schedule error, as the kit's.
        self.schedule_errors: list[list[object]] = []

    def _restart(self) -> None:
        super()._restart()
        for log in (*self.actual_schedule, *self.planner_schedule):
            log.clear()
        self.schedule_errors.clear()

    def _hand_out(self, here: np.ndarray) -> None:
        """Nothing between rounds: :meth:`assign` hands tasks out."""

    # ------------------------------------------------------------------ the rounds
    def assign(self, proposal: np.ndarray) -> None:
        """Take the entry's proposed schedule at this round (``(N,)`` task ids, -1 none),
        after the kit's checks (see the module)."""
        tick = self.steps
        proposal = np.asarray(proposal, dtype=np.int64).copy()
        for robot, task in enumerate(proposal.tolist()):
            log = self.planner_schedule[robot]
            if not log or log[-1][1] != task:
                log.append((tick, task))
        proposal = self._checked(proposal, tick)
        changed = np.flatnonzero(proposal != self.tasks)
        leaving = changed[self.tasks[changed] >= 0]
        self.open_robots[self._slot[leaving]] = -1
        self._slot[leaving] = -1
        self.tasks[leaving] = self.lines[leaving] = -1
        self.goals[leaving] = NO_ERRAND
        self.progress[leaving] = 0
        taking = changed[proposal[changed] >= 0]
        if taking.size:
            order = np.argsort(self.open_ids, kind="stable")
            slots = order[np.searchsorted(self.open_ids[order], proposal[taking])]
            self._slot[taking] = slots
            self.open_robots[slots] = taking
            ids = self.open_ids[slots]
            self._give(taking, ids, ids % self.instance.num_tasks)
        for robot, task in enumerate(self.tasks.tolist()):
            log = self.actual_schedule[robot]
            if not log or log[-1][1] != task:
                log.append((tick, task))

    def open_tasks(self) -> OpenTasks:
        """The open tasks, in the order they were revealed, as the scheduler sees them."""
        order = np.argsort(self.open_ids, kind="stable")
        ids = self.open_ids[order]
        robot = self.open_robots[order]
        lines = ids % self.instance.num_tasks
        done = np.where(robot >= 0, self.progress[np.maximum(robot, 0)], 0)
        offsets = self.instance.task_offsets
        next_stop = self.instance.task_stops[offsets[lines] + done]
        length = self._remaining_length(lines, done)
        return OpenTasks(ids, next_stop, length, robot)

    def remaining_stops(self) -> np.ndarray:
        """``(N, M)`` each robot's errands still to do, in order, padded with -1 (all -1
        for a free robot)."""
        n = len(self.tasks)
        sizes = self.instance.stops_per_task
        width = int(sizes.max(initial=1))
        stops = np.full((n, width), -1, dtype=np.int64)
        busy = np.flatnonzero(self.tasks >= 0)
        if busy.size:
            lines = self.lines[busy]
            first = self.instance.task_offsets[lines] + self.progress[busy]
            left = sizes[lines] - self.progress[busy]
            k = np.arange(width)[None, :]
            index = np.minimum(first[:, None] + k, len(self.instance.task_stops) - 1)
            stops[busy] = np.where(k < left[:, None], self.instance.task_stops[index], -1)
        return stops

    # ------------------------------------------------------------------ parts
    def _checked(self, proposal: np.ndarray, tick: int) -> np.ndarray:
        """The kit's ``validate_task_assignment``, robot by robot, its errors kept."""
        opened = {int(t): int(r) for t, r in zip(self.tasks.tolist(), range(len(self.tasks)),
                                                 strict=True) if t >= 0}  # fmt: skip
        is_open = set(self.open_ids.tolist())
        seen: dict[int, int] = {}
        progress = self.progress.tolist()
        current = self.tasks.tolist()
        task_progress = {t: progress[r] for t, r in opened.items()}
        for robot, task in enumerate(proposal.tolist()):
            if task != -1 and task not in is_open:
                self.schedule_errors.append([task, robot, -1, tick, "task already finished"])
                task = -1
            if task != -1 and task in seen:
                self.schedule_errors.append(
                    [
                        task,
                        robot,
                        seen[task],
                        tick,
                        "task is already assigned by the second agent at the same time",
                    ]
                )
                task = -1
            own = current[robot]
            if own != -1 and progress[robot] > 0 and task != own:
                self.schedule_errors.append([task, robot, -1, tick, "schedule agent to another "
                                             "task who is already opened a task"])  # fmt: skip
                task = own
            if task != -1 and task_progress.get(task, 0) > 0 and opened[task] != robot:
                self.schedule_errors.append([task, robot, opened[task], tick, "task is already "
                                             "opened by other agent"])  # fmt: skip
                task = -1
            if task != -1:
                seen[task] = robot
            proposal[robot] = task
        return proposal

    def _remaining_length(self, lines: np.ndarray, done: np.ndarray) -> np.ndarray:
        """Each task's length from its next errand (after ``done``) to its last."""
        offsets, stops = self.instance.task_offsets, self.instance.task_stops
        cols = self.instance.grid.cols
        length = self._all_lengths[lines].copy()
        for k in range(int(done.max(initial=0))):  # subtract the legs already driven
            at = done > k
            a = stops[offsets[lines[at]] + k]
            b = stops[offsets[lines[at]] + k + 1]
            length[at] -= np.abs(a // cols - b // cols) + np.abs(a % cols - b % cols)
        return length
