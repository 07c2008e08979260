"""The scheduler on true distances: a valid answer on any floor, every free robot paired
while tasks are left, the least total cost where a greedy pairing pays more, and distances
round the shelves rather than through them."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.planners.test_guidance import play
from tests.world.random_floors import shelf_layout
from warehouse_phys.envs import lorr
from warehouse_phys.lorr.errands import ScheduledTasks
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.lorr.scheduling import least_makespan, nearest_free_robot, schedule_checked
from warehouse_phys.lorr.scheduling_assignment import (
    QUANTUM,
    SCHEDULER_NAMES,
    AssignmentScheduler,
    scheduler_for,
)
from warehouse_phys.planners.distances import DistanceMaps
from warehouse_phys.rl.fleet_planners import planner_policy
from warehouse_phys.world.grid import WarehouseGrid


def random_floor(seed, rows=8, cols=9, density=0.2):
    rng = np.random.default_rng(seed)
    layout = ["".join("#" if rng.random() < density else "." for _ in range(cols))
              for _ in range(rows)]  # fmt: skip
    grid = WarehouseGrid.from_layout(layout)
    free = np.flatnonzero(np.asarray(grid.free_mask).reshape(-1))
    return grid, free, rng


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**16), robots=st.integers(0, 12), tasks=st.integers(0, 15),
       weight=st.floats(0, 3), candidates=st.integers(1, 6))  # fmt: skip
def test_every_free_robot_gets_a_task_of_its_own_while_tasks_are_left(
    seed, robots, tasks, weight, candidates
):
    grid, free, rng = random_floor(seed)
    robot_cells = rng.choice(free, robots)
    task_cells = rng.choice(free, tasks)
    lengths = rng.integers(0, 20, tasks)
    scheduler = AssignmentScheduler(grid, length_weight=weight, candidates=candidates)
    choice = schedule_checked(scheduler, robot_cells, task_cells, grid.cols, lengths)
    assert (choice >= 0).sum() == min(robots, tasks)
    assert choice.tolist() == scheduler(robot_cells, task_cells, grid.cols,
                                        task_lengths=lengths).tolist()  # fmt: skip


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**16), robots=st.integers(1, 8), tasks=st.integers(1, 8),
       weight=st.floats(0, 2))  # fmt: skip
def test_the_pairs_cost_no_more_than_a_greedy_pairing_on_the_same_distances(
    seed, robots, tasks, weight
):
    """With every task a candidate of every robot, the matching's total (true distance
    plus weighted length) is at most that of the greedy cheapest-pair-first pairing (to
    the matching's unit of cost, :data:`QUANTUM`)."""
    grid, free, rng = random_floor(seed, density=0.1)
    distances = DistanceMaps(grid)
    robot_cells = rng.choice(free, robots)
    task_cells = rng.choice(free, tasks)
    lengths = rng.integers(0, 10, tasks)
    way = distances.lookup(np.repeat(robot_cells, tasks), np.tile(task_cells, robots))
    cost = way.reshape(robots, tasks) + weight * lengths[None, :]
    if (way >= 65535).any():
        return  # a walled-off cell: both may leave a robot to the nearest fallback
    choice = AssignmentScheduler(grid, length_weight=weight, candidates=tasks,
                                 distances=distances)(robot_cells, task_cells, grid.cols,
                                                      task_lengths=lengths)  # fmt: skip
    greedy = np.full(robots, -1)
    taken = np.zeros(tasks, dtype=bool)
    for flat in np.argsort(cost, axis=None, kind="stable"):
        r, t = divmod(int(flat), tasks)
        if greedy[r] < 0 and not taken[t]:
            greedy[r], taken[t] = t, True
    mine = sum(cost[r, t] for r, t in enumerate(choice) if t >= 0)
    theirs = sum(cost[r, t] for r, t in enumerate(greedy) if t >= 0)
    assert mine <= theirs + robots / QUANTUM


def test_fractional_costs_that_once_hung_scipys_matching_are_matched(run_python):
    """Found by the test above: SciPy's LAPJVsp never returned on these fractional
    costs; in whole numbers of the unit the matching pairs all eight (a fresh process,
    so that a hang is a failure)."""
    script = (
        "import numpy as np\n"
        "from tests.lorr.test_scheduling_assignment import random_floor\n"
        "from warehouse_phys.lorr.scheduling_assignment import AssignmentScheduler\n"
        "grid, _, _ = random_floor(1243, density=0.1)\n"
        "robots = np.array([20, 33, 33, 64, 6, 35, 16, 19])\n"
        "tasks = np.array([6, 19, 4, 3, 30, 38, 36, 13])\n"
        "lengths = np.array([6, 6, 0, 0, 1, 5, 2, 6])\n"
        "scheduler = AssignmentScheduler(grid, length_weight=0.311453663543174, candidates=8)\n"
        "print(sorted(scheduler(robots, tasks, grid.cols, task_lengths=lengths).tolist()))\n"
    )
    assert run_python(script, timeout=120).strip() == str(list(range(8)))


def test_distances_go_round_the_shelves():
    """A robot beside a wall: the task just across it is 2 Manhattan moves away but 12
    round the wall; the one 5 moves down its side of the wall is nearer on the floor.
    Manhattan schedulers take the one across the wall; this one the other."""
    layout = ["...#......", "...#......", "...#......", "...#......", "...#......",
              "..........", "..........", "...#......"]  # fmt: skip
    grid = WarehouseGrid.from_layout(layout)
    cols = grid.cols
    robot = np.array([0 * cols + 2])
    tasks = np.array([0 * cols + 4, 5 * cols + 2])
    assert nearest_free_robot(robot, tasks, cols).tolist() == [0]
    assert least_makespan(robot, tasks, cols).tolist() == [0]
    assert AssignmentScheduler(grid)(robot, tasks, cols).tolist() == [1]


def test_the_errand_list_hands_tasks_out_through_it():
    grid = WarehouseGrid(5, 6)
    tasks = [[7, 20], [13, 2], [25, 4], [9, 10], [28, 0], [1, 29]]
    problem = LorrInstance(name="t", grid=grid, starts=[0, 5, 24], task_offsets=np.arange(7) * 2,
                           task_stops=np.ravel(tasks), num_tasks_reveal=2.0,
                           assignment="scheduler", version="2024 LoRR")  # fmt: skip
    errands = ScheduledTasks(problem, scheduler=AssignmentScheduler(grid))
    errands.reset(np.array([0, 5, 24]))
    assert sorted(errands.tasks.tolist()) == sorted(set(errands.tasks.tolist()))
    assert (errands.tasks >= 0).all()


def test_schedulers_by_name_and_bad_settings():
    grid = WarehouseGrid(4, 4)
    assert "assignment" in SCHEDULER_NAMES
    assert scheduler_for("nearest", grid) is nearest_free_robot
    assert isinstance(scheduler_for("assignment", grid), AssignmentScheduler)
    assert scheduler_for("assignment=1.5", grid).length_weight == 1.5
    assert scheduler_for("assignment=1000", grid).length_weight == 1000
    assert not scheduler_for("assignment", grid).rematch
    rematching = scheduler_for("rematch=0.25", grid)
    assert (rematching.rematch, rematching.length_weight, rematching.__name__) == (
        True, 0.25, "rematch")  # fmt: skip
    for bad in ("fastest", "assignment=-1", "assignment=x", "assignment=inf", "assignment=1e12",
                "rematch=-1"):  # fmt: skip
        with pytest.raises(ValueError, match=r"assignment|rematch|unknown"):
            scheduler_for(bad, grid)
    with pytest.raises(ValueError, match="length_weight"):
        AssignmentScheduler(grid, candidates=0)


@settings(max_examples=15, deadline=None)
@given(
    rows=st.integers(2, 7),
    cols=st.integers(3, 7),
    shelf_bits=st.integers(0, 2**49 - 1),
    robots=st.integers(1, 8),
    seed=st.integers(0, 2**16),
    name=st.sampled_from(["guided", "guided-repair"]),
    rematch=st.booleans(),
    cap=st.sampled_from([None, 1]),
)
def test_a_turning_fleet_scheduled_by_it_is_granted_every_move_and_replays(
    rows, cols, shelf_bits, robots, seed, name, rematch, cap
):
    """A 2024 instance on a random floor (two-stop tasks), its tasks handed out by the
    assignment, rematching or not, its stations capped or not (robots left waiting for a
    task): traffic refuses no planned move, and the same seed plays the same run."""
    try:
        grid = WarehouseGrid.from_layout(shelf_layout(rows, cols, shelf_bits))
    except ValueError:  # a floor the grid refuses (no cell but the start reached)
        return
    free = np.flatnonzero(np.asarray(grid.free_mask).reshape(-1))
    if len(free) < robots + 1:
        return
    rng = np.random.default_rng(seed)
    starts = rng.choice(free, robots, replace=False)
    firsts = rng.choice(free[:3] if cap else free, 30)  # capped: three stations, queues
    stops = np.column_stack([firsts, rng.choice(free, 30)]).ravel()
    problem = LorrInstance(name="r", grid=grid, starts=starts,
                           task_offsets=np.arange(31) * 2, task_stops=stops,
                           num_tasks_reveal=1.5, assignment="scheduler",
                           version="2024 LoRR")  # fmt: skip
    scheduler = AssignmentScheduler(grid, rematch=rematch, station_cap=cap)
    env = lorr.fleet(problem, max_cycles=30, scheduler=scheduler)
    refused, digest = play(env, planner_policy(name, seed), seed, 30)
    assert refused == 0
    assert play(env, planner_policy(name, seed), seed, 30) == (0, digest)
