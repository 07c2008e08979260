"""The start kit's task manager: schedules taken at rounds after the kit's four checks,
errands counted where the robots stand, the schedules logged as the kit writes them."""

import numpy as np

from tests.lorr.tiny_kit_instance import tiny_instance
from warehouse_phys.lorr.startkit.tasks import KitTasks


def started():
    instance = tiny_instance()
    tasks = KitTasks(instance, record=True)
    tasks.reset(instance.starts)
    return instance, tasks


def test_nothing_is_handed_out_between_rounds():
    instance, tasks = started()
    assert (tasks.tasks == -1).all()
    assert len(tasks.open_tasks().ids) == 12
    tasks.step(np.zeros(0, np.int64), instance.starts)
    assert (tasks.tasks == -1).all()
    tasks.assign(np.array([0, 1, -1, -1, -1, -1, -1, -1]))
    assert tasks.tasks[:2].tolist() == [0, 1]
    assert tasks.goals[0] == instance.task(0)[0]


def test_the_kits_four_checks_each_log_a_schedule_error():
    instance, tasks = started()
    tasks.assign(np.array([0, 1, 2, -1, -1, -1, -1, -1]))
    # Robot 2 finishes the first errand of task 2: task 2 is opened.
    tasks.step(np.array([2]), np.where(np.arange(8) == 2, instance.task(2)[0], instance.starts))
    errors_before = len(tasks.schedule_errors)
    tasks.assign(np.array([2, 1, 3, 1, -1, -1, -1, 99]))
    what = [error[4] for error in tasks.schedule_errors[errors_before:]]
    assert what == ["task is already opened by other agent",
                    "schedule agent to another task who is already opened a task",
                    "task is already assigned by the second agent at the same time",
                    "task already finished"]  # fmt: skip
    assert tasks.tasks.tolist() == [-1, 1, 2, -1, -1, -1, -1, -1]


def test_a_finished_task_frees_its_robot_and_the_logs_read_as_the_kits():
    instance, tasks = started()
    tasks.assign(np.array([0, -1, -1, -1, -1, -1, -1, -1]))
    for stop in instance.task(0).tolist():
        here = np.where(np.arange(8) == 0, stop, instance.starts)
        finished = tasks.step(np.array([0]), here)
    assert finished.tolist() == [0]
    assert tasks.tasks_done == 1
    assert tasks.tasks[0] == -1
    tasks.assign(np.array([-1, -1, -1, -1, -1, -1, -1, -1]))
    assert tasks.actual_schedule[0] == [(0, 0), (2, -1)]
    assert tasks.planner_schedule[0] == [(0, 0), (2, -1)]
    assert len(tasks.open_tasks().ids) == 12  # the finished task's slot refilled
