"""Errands from a task list, handed out as the League of Robot Runners does, and schedulers."""

import itertools

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from warehouse_phys.lorr.errands import (
    NO_ERRAND,
    GreedyErrands,
    RoundRobinErrands,
    ScheduledTasks,
    errand_list,
    task_lengths,
)
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.lorr.scheduling import (
    least_makespan,
    nearest_free_robot,
    schedule_checked,
    scheduler_named,
)
from warehouse_phys.world.grid import WarehouseGrid

GRID = WarehouseGrid(6, 7)


def instance(tasks, robots=3, assignment="roundrobin", reveal=1.0):
    """An instance on an empty 6 x 7 floor: robots on cells 0, 1, 2, ..."""
    offsets = np.cumsum([0] + [len(t) for t in tasks])
    version = "2024 LoRR" if assignment == "scheduler" else None
    return LorrInstance(
        name="t", grid=GRID, starts=list(range(robots)), task_offsets=offsets,
        task_stops=[s for t in tasks for s in t], num_tasks_reveal=reveal,
        assignment=assignment, version=version,
    )  # fmt: skip


def finish_everything(errands, steps):
    """Every robot with an errand reaches it each step; the goals seen at each step."""
    seen = [errands.goals.copy()]
    for _ in range(steps):
        arrived = np.flatnonzero(errands.goals != NO_ERRAND)
        errands.step(arrived, np.where(errands.goals >= 0, errands.goals, 0))
        seen.append(errands.goals.copy())
    return seen


def test_round_robin_gives_robot_i_its_kth_task_i_plus_k_n_modulo_the_list():
    tasks = [[10 + t] for t in range(7)]  # task t's one errand is on cell 10 + t
    errands = RoundRobinErrands(instance(tasks), record=True)
    errands.reset(np.arange(3))
    seen = finish_everything(errands, 5)
    for k, goals in enumerate(seen):
        assert goals.tolist() == [10 + (i + k * 3) % 7 for i in range(3)]
    assert errands.errands_done == errands.tasks_done == 15
    # Task ids count the tasks handed out, robot by robot.
    assert [task for _, robot, task in errands.events.assigned[:6]] == list(range(6))


def test_greedy_hands_the_next_tasks_to_free_robots_in_order_then_runs_dry():
    errands = GreedyErrands(instance([[10], [11], [12], [13]], robots=3), record=True)
    errands.reset(np.arange(3))
    assert errands.goals.tolist() == [10, 11, 12]
    errands.step(np.array([1]), np.array([0, 11, 2]))
    assert errands.goals.tolist() == [10, 13, 12]
    errands.step(np.array([0, 2]), np.array([10, 11, 12]))
    assert errands.goals.tolist() == [NO_ERRAND, 13, NO_ERRAND]  # the list is used up
    assert errands.tasks_done == 3


def test_one_errand_a_robot_and_step_and_a_stop_where_it_stands_is_finished_next_step():
    errands = RoundRobinErrands(instance([[5, 5, 6]], robots=1))
    errands.reset(np.array([0]))
    errands.step(np.array([0]), np.array([5]))
    assert errands.goals.tolist() == [5]
    assert errands.errands_done == 1
    errands.step(np.array([0]), np.array([5]))
    assert errands.goals.tolist() == [6]
    assert errands.tasks_done == 0
    errands.step(np.array([0]), np.array([6]))
    assert errands.tasks_done == 1
    assert errands.errands_done == 3


def test_scheduled_tasks_keep_the_revealed_count_open_and_refill_from_the_file_in_order():
    tasks = [[20 + t, 30 + t] for t in range(10)]
    errands = ScheduledTasks(instance(tasks, robots=2, assignment="scheduler", reveal=2),
                             record=True)  # fmt: skip
    errands.reset(np.array([20, 26]))
    assert sorted(errands.open_ids.tolist()) == [0, 1, 2, 3]  # 2 x 2 robots open
    assert errands.goals.tolist() == [20, 23]  # the nearest open tasks' first errands
    first = errands.tasks.tolist()
    for _ in range(2):  # both errands of each robot's task
        errands.step(np.array([0, 1]), errands.goals.copy())
    assert errands.tasks_done == 2
    assert errands.errands_done == 4
    assert sorted(errands.open_ids.tolist()) == sorted({0, 1, 2, 3, 4, 5} - set(first))
    # A finished task's slot takes the next of the file: ids 4 and 5 were revealed.
    assert [task for task, step, _ in errands.events.revealed if step == 2] == [4, 5]
    assert all(robot in (0, 1) for _, robot, _ in errands.events.assigned)


def test_a_robot_keeps_its_task_to_the_end_and_no_task_goes_to_two_robots():
    """With a scheduler that does not rematch (the default's rematching: its own tests)."""
    rng = np.random.default_rng(0)
    tasks = [rng.integers(0, 42, size=rng.integers(1, 4)).tolist() for _ in range(50)]
    errands = errand_list(instance(tasks, robots=6, assignment="scheduler", reveal=1.5),
                          scheduler=nearest_free_robot)  # fmt: skip
    errands.reset(np.arange(6))
    for _ in range(60):
        held = errands.tasks.copy()
        arrived = np.flatnonzero(rng.random(6) < 0.5)
        finished = errands.step(arrived, rng.integers(0, 42, size=6))
        kept = np.setdiff1d(np.arange(6), finished)
        assert (errands.tasks[kept] == held[kept]).all()
        busy = errands.tasks[errands.tasks >= 0]
        assert len(np.unique(busy)) == len(busy)
        assert np.isin(busy, errands.open_ids).all()


def test_a_scheduler_of_ones_own_is_called_and_a_bad_answer_is_refused():
    calls = []

    def farthest_last(robot_cells, task_cells, cols):
        calls.append((robot_cells.tolist(), task_cells.tolist(), cols))
        return np.arange(len(robot_cells))[::-1] % len(task_cells)

    errands = errand_list(instance([[40], [41], [39]], robots=2, assignment="scheduler",
                                   reveal=1.5), scheduler=farthest_last)  # fmt: skip
    errands.reset(np.array([0, 1]))
    assert calls == [([0, 1], [40, 41, 39], 7)]
    assert errands.goals.tolist() == [41, 40]

    def greedy_twice(robot_cells, task_cells, cols):
        return np.zeros(len(robot_cells), dtype=np.int64)

    with pytest.raises(ValueError, match="scheduler greedy_twice gave task 0 to two robots"):
        errand_list(instance([[40], [41]], robots=2, assignment="scheduler"),
                    scheduler=greedy_twice).reset(np.array([0, 1]))  # fmt: skip
    with pytest.raises(ValueError, match="must return one integer per free robot"):
        schedule_checked(lambda r, t, c: [0.5] * len(r), np.array([0]), np.array([1]), 7)
    with pytest.raises(ValueError, match="chose task 5"):
        schedule_checked(lambda r, t, c: np.array([5]), np.array([0]), np.array([1]), 7)
    with pytest.raises(ValueError, match=r"roundrobin.*scheduler=None"):
        errand_list(instance([[40]]), scheduler=nearest_free_robot)


def brute_force_nearest(robot_cells, task_cells, cols, lengths=None):
    """Pair the robot and task of least cost (Manhattan to the task's first stop, plus the
    task's length if given), ties to the lower robot then the earlier task, until one
    side runs out."""
    lengths = [0] * len(task_cells) if lengths is None else lengths
    choice = [-1] * len(robot_cells)
    pairs = sorted(
        (abs(r // cols - t // cols) + abs(r % cols - t % cols) + lengths[j], i, j)
        for (i, r), (j, t) in itertools.product(enumerate(robot_cells), enumerate(task_cells))
    )
    used = set()
    for _, i, j in pairs:
        if choice[i] < 0 and j not in used:
            choice[i] = j
            used.add(j)
    return choice


@settings(max_examples=200)
@given(robots=st.lists(st.integers(0, 99), max_size=20),
       tasks=st.lists(st.integers(0, 99), max_size=20))  # fmt: skip
@example(robots=[0] * 7, tasks=[0, 0, 0, 0, 0, 29, 29, 92, 0])  # more ties than offers
def test_the_nearest_pairing_is_the_greedy_nearest_matching(robots, tasks):
    choice = nearest_free_robot(np.array(robots, dtype=np.int64), np.array(tasks, np.int64), 10)
    assert choice.tolist() == brute_force_nearest(robots, tasks, 10)


@settings(max_examples=200)
@given(robots=st.lists(st.integers(0, 99), max_size=20),
       tasks=st.lists(st.tuples(st.integers(0, 99), st.integers(0, 30)), max_size=20))  # fmt: skip
@example(robots=[0] * 7, tasks=[(0, 0)] * 5 + [(29, 0), (29, 3), (92, 1), (0, 2)])
def test_the_makespan_pairing_is_the_greedy_least_makespan_matching(robots, tasks):
    cells = np.array([t for t, _ in tasks], dtype=np.int64)
    lengths = np.array([length for _, length in tasks], dtype=np.int64)
    choice = least_makespan(np.array(robots, dtype=np.int64), cells, 10, task_lengths=lengths)
    assert choice.tolist() == brute_force_nearest(robots, cells.tolist(), 10, lengths)
    # Without lengths it is the nearest pairing.
    plain = least_makespan(np.array(robots, dtype=np.int64), cells, 10)
    assert plain.tolist() == nearest_free_robot(np.array(robots, np.int64), cells, 10).tolist()


def test_a_shorter_task_goes_first_by_makespan_and_bad_lengths_are_refused():
    # One robot on cell 0; the nearer task is long, the farther one short.
    robots, tasks = np.array([0]), np.array([1, 3])
    assert nearest_free_robot(robots, tasks, 7).tolist() == [0]
    assert least_makespan(robots, tasks, 7, task_lengths=np.array([10, 2])).tolist() == [1]
    for bad in (np.array([1]), np.array([1, -1]), np.array([1.0, 2.0])):
        with pytest.raises(ValueError, match="task_lengths must be one integer >= 0"):
            least_makespan(robots, tasks, 7, task_lengths=bad)
    assert scheduler_named("makespan") is least_makespan
    with pytest.raises(ValueError, match="unknown scheduler 'fastest'; known: nearest, makespan"):
        scheduler_named("fastest")


def test_task_lengths_are_the_manhattan_legs_between_a_tasks_stops():
    # On the 6 x 7 floor: 8 = (1, 1), 20 = (2, 6), 0 = (0, 0), 41 = (5, 6).
    tasks = [[8, 20], [0], [41, 0, 8]]
    assert task_lengths(instance(tasks, assignment="scheduler")).tolist() == [6, 0, 13]


def test_the_errand_list_gives_task_lengths_to_a_scheduler_that_takes_them():
    seen = []

    def with_lengths(robot_cells, task_cells, cols, *, task_lengths):
        seen.append(task_lengths.tolist())
        return least_makespan(robot_cells, task_cells, cols, task_lengths=task_lengths)

    # Robot 0 on cell 0: task 0 is nearer (cell 1) but long; task 1 (cell 3) short.
    tasks = [[1, 41], [3, 4], [5, 12]]
    errands = errand_list(instance(tasks, robots=1, assignment="scheduler", reveal=3),
                          scheduler=with_lengths)  # fmt: skip
    errands.reset(np.array([0]))
    assert seen == [[10, 1, 1]]
    assert errands.goals.tolist() == [3]
    nearest = errand_list(instance(tasks, robots=1, assignment="scheduler", reveal=3),
                          scheduler=nearest_free_robot)  # fmt: skip
    nearest.reset(np.array([0]))
    assert nearest.goals.tolist() == [1]
