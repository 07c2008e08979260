"""The congestion-free task flow of an instance: what its errand list and scheduler would
finish if robots never met.

:func:`congestion_free_flow` plays an instance's errand list
(:func:`~warehouse_phys.lorr.errands.errand_list`, its scheduler included) with robots
that drive a Manhattan path to their errand, one cell a step (along its row first),
through each other: no shelves in the way, no turns, no waiting. A robot finishes an
errand on the step it arrives, and sets off for its next one on the step after, as the
fleet counts (one errand a step at most). The errand list sees where each robot stands
every step, so a rematching scheduler
(:class:`~warehouse_phys.lorr.scheduling_assignment.AssignmentScheduler`, the default)
may pair a robot on its way with another task, as it does the fleet's robots: the robot
turns to its new errand from where it stands (or stops, left without a task). So it
separates what the task list and the scheduler
allow from what planning loses to traffic: a planner's figure beside it says how much of
the flow the traffic took. It is a model, not a bound: on a floor with shelves a path is
longer than the Manhattan distance, turning robots turn, and a real fleet's robots come
free at other times and places, so a scheduler may hand them other tasks. On an empty
floor with one robot it is the fleet's own count (tests/lorr/test_task_flow.py).

O(N) array work a step plus the scheduler's own. Like :mod:`warehouse_phys.world.grid`,
this module imports neither gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from warehouse_phys.lorr.errands import NO_ERRAND, errand_list
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.lorr.scheduling import Scheduler


@dataclass(frozen=True)
class TaskFlow:
    """What :func:`congestion_free_flow` counted."""

    #: Steps played.
    steps: int
    #: Errands finished by the end of each step, ``(steps,)``.
    errands_done: np.ndarray
    #: Tasks finished by the end of each step, ``(steps,)``.
    tasks_done: np.ndarray
    #: Cells driven over the run (one a robot a step, towards its errand).
    moves: int

    @property
    def errands_per_step(self) -> float:
        return float(self.errands_done[-1]) / self.steps if self.steps else 0.0

    @property
    def tasks_per_step(self) -> float:
        return float(self.tasks_done[-1]) / self.steps if self.steps else 0.0


def congestion_free_flow(
    instance: LorrInstance, steps: int, *, scheduler: Scheduler | None = None
) -> TaskFlow:
    """``instance``'s errand list played for ``steps`` steps by robots that never meet (see
    the module); ``scheduler`` as the fleet's (2024 and later instances; None: the
    default).

    Raises:
        ValueError: for ``steps`` below 1, or a scheduler on a 2023 instance (as the
            fleet).
    """
    if steps < 1:
        raise ValueError(f"steps must be at least 1, got {steps!r}")
    errands = errand_list(instance, scheduler=scheduler)
    cols = instance.grid.cols
    here = np.asarray(instance.starts[: instance.team_size], dtype=np.int64).copy()
    errands.reset(here)
    moves = 0
    errands_done = np.empty(steps, dtype=np.int64)
    tasks_done = np.empty(steps, dtype=np.int64)
    for step in range(1, steps + 1):
        # Every robot with an errand drives one cell towards it (its row first), from
        # where it stands: a robot the scheduler paired again on the way turns to its new
        # errand from there, and a robot left without a task stops.
        going = np.flatnonzero(errands.goals != NO_ERRAND)
        goal = errands.goals[going]
        rows, columns = np.divmod(here[going], cols)
        to_rows, to_columns = np.divmod(goal, cols)
        d_row = np.sign(to_rows - rows)
        d_col = np.where(d_row == 0, np.sign(to_columns - columns), 0)
        moved = (d_row != 0) | (d_col != 0)
        here[going] += d_row * cols + d_col
        moves += int(np.count_nonzero(moved))
        # On its errand at the end of the step: finished (one errand a step at most).
        errands.step(going[here[going] == goal], here)
        errands_done[step - 1] = errands.errands_done
        tasks_done[step - 1] = errands.tasks_done
    return TaskFlow(steps, errands_done, tasks_done, moves)
