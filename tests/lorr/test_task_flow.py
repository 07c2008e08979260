"""The congestion-free task flow: the fleet's own count where robots cannot meet."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.envs import fleet
from warehouse_phys.lorr.errands import NO_ERRAND, errand_list
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.lorr.scheduling import least_makespan
from warehouse_phys.lorr.task_flow import congestion_free_flow
from warehouse_phys.rl.fleet_planners import pibt_policy
from warehouse_phys.world.grid import WarehouseGrid

GRID = WarehouseGrid(6, 7)


def one_robot(stops, per_task, assignment):
    tasks = len(stops) // per_task
    return LorrInstance(
        name="one", grid=GRID, starts=[stops[-1]], task_offsets=np.arange(tasks + 1) * per_task,
        task_stops=stops[: tasks * per_task], num_tasks_reveal=2.0, assignment=assignment,
        version="2024 LoRR" if assignment == "scheduler" else None,
    )  # fmt: skip


@settings(max_examples=25, deadline=None)
@given(stops=st.lists(st.integers(0, 41), min_size=4, max_size=12),
       scheduled=st.booleans())  # fmt: skip
def test_one_robot_on_an_empty_floor_finishes_what_the_flow_says(stops, scheduled):
    """One robot cannot meet another, and on an empty floor PIBT drives it a Manhattan
    path: the fleet's errands and tasks, step by step, are the flow's."""
    per_task, assignment = (2, "scheduler") if scheduled else (1, "roundrobin")
    instance = one_robot(stops, per_task, assignment)
    steps = 40
    flow = congestion_free_flow(instance, steps)
    env = fleet.parallel_env(instance=instance, moves="grid", max_cycles=steps)
    observations, infos = env.reset(seed=0)
    policy = pibt_policy(0)
    for step in range(steps):
        observations, _, _, _, infos = env.step(policy(env, observations, infos))
        assert env.errands.errands_done == flow.errands_done[step]
        assert env.errands.tasks_done == flow.tasks_done[step]
    assert flow.errands_per_step == flow.errands_done[-1] / steps


def test_the_flow_counts_moves_and_weighs_the_scheduler():
    # Robots on 0 and 6 (row 0's ends); tasks: a long one near robot 0, short ones farther.
    stops = [1, 41, 3, 4, 5, 12, 2, 9]
    instance = LorrInstance(
        name="two", grid=GRID, starts=[0, 6], task_offsets=np.arange(5) * 2, task_stops=stops,
        num_tasks_reveal=1.5, assignment="scheduler", version="2024 LoRR",
    )  # fmt: skip
    nearest = congestion_free_flow(instance, 30)
    makespan = congestion_free_flow(instance, 30, scheduler=least_makespan)
    assert nearest.tasks_done.tolist() != makespan.tasks_done.tolist()
    assert (np.diff(nearest.tasks_done) >= 0).all()
    assert nearest.moves > 0
    with pytest.raises(ValueError, match="steps must be at least 1"):
        congestion_free_flow(instance, 0)


WIDE = WarehouseGrid(8, 20)


def fleet_of(starts, stops):
    tasks = len(stops) // 2
    return LorrInstance(
        name="fleet", grid=WIDE, starts=starts, task_offsets=np.arange(tasks + 1) * 2,
        task_stops=stops[: tasks * 2], num_tasks_reveal=1.5, assignment="scheduler",
        version="2024 LoRR",
    )  # fmt: skip


def flow_robot_by_robot(instance, steps):
    """The flow's rule played robot by robot: each drives one cell towards its errand as
    it is now (its row first) and finishes it on arriving; also counts the robots paired
    again with another task on their way (the default scheduler rematches) and the cells
    driven."""
    errands = errand_list(instance)
    cols = instance.grid.cols
    here = np.array(instance.starts, dtype=np.int64)
    errands.reset(here)
    counts, paired_again, driven = [], 0, 0
    for _ in range(steps):
        arrived = []
        for robot, goal in enumerate(errands.goals.tolist()):
            if goal == NO_ERRAND:
                continue
            (row, col), (to_row, to_col) = divmod(int(here[robot]), cols), divmod(goal, cols)
            if row != to_row:
                row += 1 if to_row > row else -1
            elif col != to_col:
                col += 1 if to_col > col else -1
            driven += here[robot] != row * cols + col
            here[robot] = row * cols + col
            if here[robot] == goal:
                arrived.append(robot)
        before = errands.goals.copy()
        errands.step(np.array(arrived, dtype=np.int64), here)
        changed = (errands.goals != before) & (before != NO_ERRAND)
        changed[arrived] = False
        paired_again += int(changed.sum())
        counts.append((errands.errands_done, errands.tasks_done))
    return counts, paired_again, driven


def flow_counts(flow):
    return list(zip(flow.errands_done.tolist(), flow.tasks_done.tolist(), strict=True))


@settings(max_examples=25, deadline=None)
@given(data=st.data(), robots=st.integers(2, 10))
def test_robots_paired_again_on_their_way_drive_to_their_new_errand(data, robots):
    """The rematching scheduler gives robots on their way new tasks (and may leave one
    without): each turns to its new errand from where it stands, as the fleet's robots
    do, and finishes only the errands it reaches."""
    starts = data.draw(st.lists(st.integers(0, 159), min_size=robots, max_size=robots,
                                unique=True))  # fmt: skip
    stops = data.draw(st.lists(st.integers(0, 159), min_size=4, max_size=60))
    instance = fleet_of(starts, stops)
    flow = congestion_free_flow(instance, 40)
    counts, _, driven = flow_robot_by_robot(instance, 40)
    assert flow_counts(flow) == counts
    assert flow.moves == driven


def test_a_fleet_whose_robots_are_paired_again_is_counted_as_they_drive():
    stops = [60, 10, 67, 76, 106, 91, 72, 35, 93, 72, 134, 111, 116, 91, 58, 45]
    instance = fleet_of([140, 122, 146, 40, 11], stops)
    counts, paired_again, _ = flow_robot_by_robot(instance, 40)
    assert paired_again > 0  # the case this test is for
    assert flow_counts(congestion_free_flow(instance, 40)) == counts
