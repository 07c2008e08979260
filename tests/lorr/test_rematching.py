"""Rematching: robots on their way to a task not opened yet go back into the pairing (those
far enough from their first errand, the farthest first, a bounded number), and the
fleet's errand list with a rematching scheduler keeps every promise of the kit's checks."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.lorr import rematching
from warehouse_phys.lorr.errands import ScheduledTasks
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.lorr.rematching import KEEP_WITHIN, rematch_candidates
from warehouse_phys.lorr.scheduling_assignment import AssignmentScheduler, scheduler_for
from warehouse_phys.world.grid import WarehouseGrid

GRID = WarehouseGrid(6, 7)


def test_robots_near_their_first_errand_keep_it_and_the_farthest_come_first(monkeypatch):
    cols = GRID.cols
    cells = np.array([0, 0, 0, 0])
    firsts = np.array([KEEP_WITHIN, KEEP_WITHIN + 1, 5 * cols, 3 * cols])  # ways 2, 3, 5, 3
    assert rematch_candidates(cells, firsts, cols).tolist() == [1, 2, 3]
    monkeypatch.setattr(rematching, "REMATCH_MAX", 2)
    assert rematch_candidates(cells, firsts, cols).tolist() == [1, 2]  # 5 moves, then 3
    assert rematch_candidates(cells[:0], firsts[:0], cols).tolist() == []


def instance(tasks, starts):
    offsets = np.cumsum([0] + [len(t) for t in tasks])
    return LorrInstance(name="t", grid=GRID, starts=starts, task_offsets=offsets,
                        task_stops=[s for t in tasks for s in t], num_tasks_reveal=1.0,
                        assignment="scheduler", version="2024 LoRR")  # fmt: skip


def test_a_robot_on_its_way_takes_a_task_revealed_beside_it_and_gives_its_own_away():
    # Robot 0 (cell 0) takes task 0 (its errand at cell 35, 5 moves), robot 1 (cell 40)
    # task 1 (cell 41). Robot 1 finishes; task 2, revealed then, is at cell 1, beside
    # robot 0 (now at cell 7, 4 moves from cell 35): rematched, robot 0 takes task 2 and
    # robot 1 task 0 (2 + 6 moves between them, against 4 + 10).
    tasks = [[35], [41], [1], [4], [5]]
    rematched = ScheduledTasks(instance(tasks, [0, 40]), record=True,
                               scheduler=AssignmentScheduler(GRID, rematch=True))  # fmt: skip
    plain = ScheduledTasks(instance(tasks, [0, 40]), scheduler=AssignmentScheduler(GRID))
    for run in (rematched, plain):
        run.reset(np.array([0, 40]))
        assert run.tasks.tolist() == [0, 1]
        run.step(np.array([1]), np.array([7, 41]))  # robot 1 ends on its only errand
    assert plain.tasks.tolist() == [0, 2]  # robot 0 keeps the far task
    assert rematched.tasks.tolist() == [2, 0]
    assert rematched.goals.tolist() == [1, 35]
    assert rematched.events.assigned[-2:] == [(1, 0, 2), (1, 1, 0)]


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 8), st.sampled_from([1.0, 1.5, 3.0]))
def test_an_opened_task_stays_no_task_goes_twice_and_no_robot_idles_while_tasks_wait(
    seed, robots, reveal
):
    rng = np.random.default_rng(seed)
    tasks = [rng.integers(0, 42, size=rng.integers(1, 4)).tolist() for _ in range(60)]
    problem = instance(tasks, list(range(robots)))
    problem = LorrInstance(**{**problem.__dict__, "num_tasks_reveal": reveal})
    errands = ScheduledTasks(problem, scheduler=scheduler_for("rematch", GRID))
    here = rng.integers(0, 42, size=robots)
    errands.reset(here)
    for _ in range(40):
        held, opened = errands.tasks.copy(), errands.progress > 0
        arrived = np.flatnonzero(rng.random(robots) < 0.4)
        here = rng.integers(0, 42, size=robots)
        finished = errands.step(arrived, here)
        still = opened & ~np.isin(np.arange(robots), finished)
        assert (errands.tasks[still] == held[still]).all()  # an opened task stays
        busy = errands.tasks[errands.tasks >= 0]
        assert len(np.unique(busy)) == len(busy)
        assert np.isin(busy, errands.open_ids).all()
        assert len(busy) == min(robots, len(errands.open_ids))
        assert (errands.open_robots >= 0).sum() == len(busy)
