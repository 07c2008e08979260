"""The congestion-free task flow: the fleet's own count where robots cannot meet."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.envs import fleet
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
