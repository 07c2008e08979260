"""The entry's scheduler: robots keep their tasks, free robots take untaken ones, and a task
held for a robot about to be free is proposed for it once the kit frees it."""

import numpy as np
import pytest

from warehouse_phys.lorr.startkit.scheduler import EntryScheduler, OpenTasks

COLS = 10


def tasks(ids, stops, robots, lengths=None):
    lengths = [0] * len(ids) if lengths is None else lengths
    return OpenTasks(*(np.array(v, dtype=np.int64) for v in (ids, stops, lengths, robots)))


def test_robots_keep_their_tasks_and_free_ones_take_the_nearest_untaken():
    scheduler = EntryScheduler(COLS, "nearest")
    pool = tasks([4, 5, 6], [0, 55, 99], [1, -1, -1])
    proposal = scheduler.schedule(np.array([-1, 4, -1]), np.array([98, 0, 56]), pool)
    assert proposal.tolist() == [6, 4, 5]


def test_makespan_prefers_the_shorter_task_of_two_equally_near():
    scheduler = EntryScheduler(COLS, "makespan")
    pool = tasks([1, 2], [11, 13], [-1, -1], lengths=[9, 1])
    assert scheduler.schedule(np.array([-1]), np.array([12]), pool).tolist() == [2]


def test_a_task_held_for_a_finishing_robot_is_proposed_once_it_is_free():
    scheduler = EntryScheduler(COLS, "nearest")
    pool = tasks([7, 8], [21, 90], [0, -1])
    first = scheduler.schedule(np.array([7, -1]), np.array([20, 95]), pool,
                               finishing=np.array([True, False]))  # fmt: skip
    assert first.tolist() == [7, 8]  # robot 0 keeps its task for the kit; robot 1 takes 8
    pool = tasks([8, 9, 10], [90, 22, 23], [1, -1, -1])
    second = scheduler.schedule(np.array([7, 8]), np.array([20, 95]), pool,
                                finishing=np.array([True, False]))  # fmt: skip
    assert scheduler.held.tolist() == [9, -1]
    # The kit freed robot 0: it is proposed for the task held for it, no other robot for it.
    pool = tasks([8, 9, 10], [90, 22, 23], [1, -1, -1])
    third = scheduler.schedule(np.array([-1, 8]), np.array([21, 95]), pool)
    assert (second.tolist(), third.tolist(), scheduler.held.tolist()) == ([7, 8], [9, 8], [-1, -1])


def test_an_unknown_scheduler_is_refused():
    with pytest.raises(ValueError, match="unknown scheduler 'hungarian'"):
        EntryScheduler(COLS, "hungarian")
