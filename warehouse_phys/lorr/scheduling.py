"""Schedulers: which free robot takes which open task (LoRR 2024 and later).

A :data:`Scheduler` is any callable ``scheduler(robot_cells, task_cells, cols)``:

- ``robot_cells``: ``(F,)`` int64, the cell index (``row * cols + col``) of every free
  robot, in robot order;
- ``task_cells``: ``(K,)`` int64, the first errand of every open task that no robot
  has taken, in the order the tasks were revealed;
- ``cols``: the floor's width, to turn a cell index into ``divmod(cell, cols)``;

returning ``(F,)`` integers: for each free robot the position in ``task_cells`` of the
task it takes, or -1 to leave it free this step. No task may go to two robots;
:func:`schedule_checked` refuses any other answer with a ``ValueError``. A scheduler
that has a keyword parameter ``task_lengths`` is also given ``(K,)`` int64, each open
task's length from its first errand to its last (Manhattan, the moves between its
stops). The errand list (:class:`~warehouse_phys.lorr.errands.ScheduledTasks`) calls
it after every step with the robots that are free then; a robot keeps its task to the
task's end.

The built-in schedulers pair free robots and open tasks greedily, cheapest pair first:

- :func:`nearest_free_robot` (the default) by the distance from the robot to the task's
  first errand;
- :func:`least_makespan` by the task's *makespan*, that distance plus the task's own
  length, as the competition's default entry does: of tasks equally near, the shorter
  goes first. On 2024 WAREHOUSE's 5,000 steps it finished 1-3 % more tasks than the
  nearest pairing with guided or plain PIBT, far more in the first few hundred steps,
  and fewer with robots that never meet (the open tasks left are the long ones:
  :mod:`warehouse_phys.lorr.task_flow`).

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable

import numpy as np

#: A scheduler: free robots' cells, open tasks' first errands, the floor's width ->
#: the task each free robot takes (-1: none).
Scheduler = Callable[[np.ndarray, np.ndarray, int], np.ndarray]

#: Tasks each free robot is offered per round of the greedy pairing (its nearest).
NEAREST_OFFERED = 8


def nearest_free_robot(robot_cells: np.ndarray, task_cells: np.ndarray, cols: int) -> np.ndarray:
    """Greedy nearest pairing: the free robot and open task nearest each other (Manhattan
    distance from the robot to the task's first errand) are paired first, then the
    nearest of the rest, until robots or tasks run out; ties go to the lower robot, then
    the earlier task. Every free robot gets a task while tasks are left.

    Each round offers every unpaired robot its :data:`NEAREST_OFFERED` nearest unpaired
    tasks (a k-d tree) and accepts pairs nearest first: O((F + K) log K) a round, and a
    round pairs most robots (a robot all of whose offers were taken waits for the next, and
    a round stops at an offer that ties with tasks the tree may have left out).
    The distance ignores shelves: it is what the competition's default scheduler
    measures first, not the path's length (which would cost a distance map per task).
    """
    robot_cells = np.asarray(robot_cells, dtype=np.int64)
    task_cells = np.asarray(task_cells, dtype=np.int64)
    return _greedy_pairs(_points(robot_cells, cols), _points(task_cells, cols))


def least_makespan(
    robot_cells: np.ndarray,
    task_cells: np.ndarray,
    cols: int,
    *,
    task_lengths: np.ndarray | None = None,
) -> np.ndarray:
    """Greedy pairing by makespan: the free robot and open task whose makespan (Manhattan
    distance from the robot to the task's first errand, plus ``task_lengths``, the task's
    own length) is least are paired first, then the least of the rest, ties as
    :func:`nearest_free_robot` (which this is without ``task_lengths``). The competition's
    default entry pairs by the same makespan (robot by robot, with distances round the
    shelves); here it is Manhattan and cheapest pair first, in the same
    O((F + K) log K) rounds: the length is a third coordinate of the task's point (the
    robots' is 0), so that the k-d tree's Manhattan distance is the makespan.

    Raises:
        ValueError: if ``task_lengths`` is not one length >= 0 for each task.
    """
    robot_cells = np.asarray(robot_cells, dtype=np.int64)
    task_cells = np.asarray(task_cells, dtype=np.int64)
    lengths = np.zeros(len(task_cells), np.int64) if task_lengths is None else task_lengths
    lengths = np.asarray(lengths)
    if lengths.shape != task_cells.shape or lengths.dtype.kind not in "iu" or (lengths < 0).any():
        raise ValueError(f"task_lengths must be one integer >= 0 for each of the "
                         f"{len(task_cells)} tasks, got {task_lengths!r}")  # fmt: skip
    robots = np.column_stack([_points(robot_cells, cols), np.zeros(len(robot_cells), np.int64)])
    tasks = np.column_stack([_points(task_cells, cols), lengths.astype(np.int64)])
    return _greedy_pairs(robots, tasks)


#: The built-in schedulers by name (``simulate --scheduler``, the benchmarks).
SCHEDULERS: dict[str, Scheduler] = {"nearest": nearest_free_robot, "makespan": least_makespan}


def scheduler_named(name: str) -> Scheduler:
    """The built-in scheduler called ``name`` (a key of :data:`SCHEDULERS`).

    Raises:
        ValueError: naming the known schedulers, for another name.
    """
    if name not in SCHEDULERS:
        raise ValueError(f"unknown scheduler {name!r}; known: {', '.join(SCHEDULERS)}")
    return SCHEDULERS[name]


def takes_task_lengths(scheduler: Scheduler) -> bool:
    """Whether ``scheduler`` has a keyword parameter ``task_lengths`` (see the module)."""
    try:
        parameters = inspect.signature(scheduler).parameters
    except (TypeError, ValueError):  # a callable without a signature: the three arguments
        return False
    return "task_lengths" in parameters and parameters["task_lengths"].kind in (
        inspect.Parameter.KEYWORD_ONLY,
        inspect.Parameter.POSITIONAL_OR_KEYWORD,
    )


def _points(cells: np.ndarray, cols: int) -> np.ndarray:
    """``(len(cells), 2)`` int64: each cell's ``(row, col)``."""
    return np.stack(np.divmod(cells, cols), axis=1)


def _greedy_pairs(robot_at: np.ndarray, task_at: np.ndarray) -> np.ndarray:
    """The greedy matching of robots and tasks, points in as many dimensions as given, by
    their Manhattan distance, least first (ties: the lower robot, then the earlier task):
    for each robot the task it takes, -1 for none. See :func:`nearest_free_robot`."""
    from scipy.spatial import cKDTree  # here: 0.3 s to import, for the fleets that schedule

    choice = np.full(len(robot_at), -1, dtype=np.int64)
    robots = np.arange(len(robot_at))
    tasks = np.arange(len(task_at))
    offered = NEAREST_OFFERED
    while robots.size and tasks.size:
        k = min(offered, tasks.size)
        distance, nearest = cKDTree(task_at[tasks]).query(robot_at[robots], k=k, p=1)
        distance = np.asarray(distance, dtype=np.float64).reshape(len(robots), k)
        offers = tasks[np.asarray(nearest).reshape(len(robots), k)]
        who = np.repeat(robots, k)
        order = np.lexsort((offers.ravel(), who, distance.ravel()))
        # An offer as far as a robot's last is uncertain unless every task was offered:
        # the tree may have left out an earlier task at that distance. The pairs are
        # taken in order up to the first uncertain one a free robot meets.
        uncertain = (distance >= distance[:, -1:]).ravel() & (k < tasks.size)
        taken = np.zeros(len(task_at), dtype=bool)
        for robot, task, unsure in zip(who[order].tolist(), offers.ravel()[order].tolist(),
                                       uncertain[order].tolist(), strict=True):  # fmt: skip
            if choice[robot] >= 0:
                continue
            if unsure:
                break
            if not taken[task]:
                choice[robot] = task
                taken[task] = True
        robots = robots[choice[robots] < 0]
        tasks = tasks[~taken[tasks]]
        offered *= 2  # the robots left over lost their nearest: look further
    return choice


def schedule_checked(
    scheduler: Scheduler,
    robot_cells: np.ndarray,
    task_cells: np.ndarray,
    cols: int,
    task_lengths: np.ndarray | None = None,
) -> np.ndarray:
    """``scheduler``'s answer for these robots and tasks, checked: ``(F,)`` int64, each
    -1 or a position in ``task_cells``, no task twice. ``task_lengths`` are passed on
    to a scheduler that takes them (:func:`takes_task_lengths`).

    Raises:
        ValueError: naming what is wrong with the answer.
    """
    if task_lengths is not None and takes_task_lengths(scheduler):
        answer = scheduler(robot_cells.copy(), task_cells.copy(), int(cols),
                           task_lengths=np.asarray(task_lengths).copy())  # fmt: skip
    else:
        answer = scheduler(robot_cells.copy(), task_cells.copy(), int(cols))
    name = getattr(scheduler, "__name__", type(scheduler).__name__)
    choice = np.asarray(answer)
    if choice.shape != robot_cells.shape or choice.dtype.kind not in "iu":
        raise ValueError(
            f"scheduler {name} must return one integer per free robot ({len(robot_cells)}), "
            f"got {type(answer).__name__} of shape {choice.shape} and dtype {choice.dtype}"
        )
    choice = choice.astype(np.int64)
    bad = (choice < -1) | (choice >= len(task_cells))
    if bad.any():
        raise ValueError(
            f"scheduler {name} chose task {int(choice[bad][0])} for a free robot; the "
            f"open tasks are 0..{len(task_cells) - 1} (or -1 for none)"
        )
    taken = choice[choice >= 0]
    if len(np.unique(taken)) != len(taken):
        values, counts = np.unique(taken, return_counts=True)
        raise ValueError(f"scheduler {name} gave task {int(values[counts > 1][0])} to two robots")
    return choice
