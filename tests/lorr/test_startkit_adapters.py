"""The adapters' reading of the kit's environment, on stand-ins for its MAPF types (the kit's
own are tested in test_startkit_runs.py): the task book reads each task once, the queue walk
follows the staged actions, the kit's floor read from its map."""

from types import SimpleNamespace

import numpy as np
import pytest

from tests.lorr.tiny_kit_instance import tiny_instance
from warehouse_phys.lorr.startkit import adapters


class Pool(dict):
    """A task pool that counts the reads of each task's errands."""

    reads = 0

    def __getitem__(self, key):
        task = super().__getitem__(key)
        return task


def task(stops, done=0):
    counter = {"reads": 0}

    class Task:
        idx_next_loc = done

        @property
        def locations(self):
            counter["reads"] += 1
            return list(stops)

    return Task(), counter


def test_the_book_reads_each_tasks_errands_once_and_the_schedule_gives_their_robots():
    instance = tiny_instance()
    cols = instance.grid.cols
    made = {t: task(instance.task(t).tolist(), done=1 if t == 2 else 0) for t in range(4)}
    pool = Pool({t: made[t][0] for t in made})
    book = adapters.TaskBook(cols)
    schedule = np.array([2, -1, 0, -1, -1, -1, -1, -1])
    for _ in range(3):
        tasks = book.open_tasks(pool, schedule)
    assert all(counter["reads"] == 1 for _, counter in made.values())
    assert tasks.ids.tolist() == [0, 1, 2, 3]
    assert tasks.robot.tolist() == [2, -1, 0, -1]
    assert tasks.next_stop[2] == instance.task(2)[1]  # robot 0 did task 2's first errand
    assert tasks.length[2] == 0
    assert tasks.length[1] > 0
    stops = book.stops_of(pool, schedule)
    assert stops[0].tolist()[:1] == [instance.task(2)[1]]
    assert (stops[1] == -1).all()
    del pool[1]
    assert book.update(pool) == [0, 2, 3]


def test_the_queue_walk_follows_the_staged_actions():
    instance = tiny_instance()
    grid = instance.grid
    state = SimpleNamespace(location=int(4 * grid.cols + 4), orientation=0)
    env = SimpleNamespace(system_states=[state], staged_actions=[[0, 1, 0, 2]], num_of_agents=1)
    ahead = adapters.neighbour_table(grid)[:, adapters.HEADING_MOVES]
    cells = adapters.queue_cells(env, ahead)
    c = 4 * grid.cols + 4
    # Forward east, turn south, forward south, turn back east.
    assert cells.tolist() == [[c, c + 1, c + 1, c + 1 + grid.cols, c + 1 + grid.cols]]


def test_the_kits_map_is_our_floor():
    instance = tiny_instance()
    grid = instance.grid
    env = SimpleNamespace(map=(~grid.free_mask).astype(int).ravel().tolist(), rows=grid.rows,
                          cols=grid.cols)  # fmt: skip
    assert (adapters.kit_grid(env).free_mask == grid.free_mask).all()


def test_the_executor_takes_its_planners_plan_only_when_it_is_the_kits():
    plan = np.array([[0, 1, 3], [3, 3, 3], [2, 0, 0]])
    kits = [list(row) for row in plan.tolist()]  # stand-in for the kit's Plan.actions
    adapters._PLANNED[:] = [plan]
    assert adapters.plan_table(kits, 3) is plan  # this interpreter's plan, taken as it is
    assert not adapters._PLANNED
    other = [[0], [1, 2], []]  # another plan (the planner's answer never came): read
    adapters._PLANNED[:] = [plan]
    assert adapters.plan_table(other, 3).tolist() == [[0, 3], [1, 2], [3, 3]]
    assert adapters.plan_table(kits, 3).tolist() == plan.tolist()  # none kept: read


def test_call_timings_give_wall_and_cpu_medians_and_the_share_over_the_limit(tmp_path):
    from warehouse_phys.lorr.startkit.runs import call_timings

    path = tmp_path / "ours.timings"
    path.write_text("plan 0.5 0.2\nschedule 0.6 0.1\nplan 0.3 0.25\nschedule 0.1 0.05\n"
                    "next_command 0.2 0.01\nprocess_new_plan 0.05\n")  # fmt: skip
    timings = call_timings(path)
    assert timings["plan"]["count"] == 2
    assert timings["plan"]["median_ms"] == pytest.approx(500)
    assert timings["plan"]["cpu_median_ms"] == pytest.approx(250)
    assert timings["round"]["over_limit"] == 0.5  # 1.1 s and 0.4 s
    assert timings["round"]["cpu_median_ms"] == pytest.approx(300)
    assert timings["next_command"]["over_limit"] == 1.0
    assert "cpu_median_ms" not in timings["process_new_plan"]  # an older file: wall only
