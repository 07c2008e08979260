"""The competition's output file: its documented fields, and a replay of its paths."""

import json

import numpy as np
import pytest

from tests.envs.test_fleet_instances import small_instance
from warehouse_phys.apps.simulate.lockstep import simulate
from warehouse_phys.envs import fleet
from warehouse_phys.lorr.output import (
    GRID_LETTERS,
    RunRecord,
    output_json,
    replay,
    write_output,
)
from warehouse_phys.rl.fleet_planners import pibt_policy

STEPS = 40


def recorded_run(assignment, moves):
    env = fleet.parallel_env(instance=small_instance(assignment, robots=6), moves=moves,
                             record_errands=True)  # fmt: skip
    record = RunRecord(env.num_robots, turning=env.turning)
    simulate(env, pibt_policy(0), steps=STEPS, record=record)
    return env, record


@pytest.mark.parametrize("moves", ["grid", "rotate"])
@pytest.mark.parametrize("assignment", ["roundrobin", "scheduler"])
def test_the_output_has_the_documented_fields_and_its_paths_replay_without_conflict(
    tmp_path, assignment, moves
):
    env, record = recorded_run(assignment, moves)
    path = write_output(tmp_path / "out.json", env.instance, record, env.errands)
    output = json.loads(path.read_text())
    assert output["actionModel"] == ("MAPF_T" if moves == "rotate" else "MAPF")
    assert output["teamSize"] == 6
    assert output["start"][1] == [0, 1, "E"]
    assert output["numTaskFinished"] == env.errands.tasks_done
    assert output["makespan"] <= STEPS
    assert output["sumOfCost"] <= 6 * STEPS
    assert len(output["plannerTimes"]) == STEPS
    assert output["errors"] == []
    letters = set("FRCW" if moves == "rotate" else GRID_LETTERS)
    for path_text in output["actualPaths"] + output["plannerPaths"]:
        actions = path_text.split(",")
        assert len(actions) == STEPS
        assert set(actions) <= letters
    walked = replay(output, env.grid)
    assert walked.conflicts == []
    cols = env.grid.cols
    assert walked.cells[-1].tolist() == (env.robot_cells @ [cols, 1]).tolist()
    if moves == "rotate":
        assert walked.headings[-1].tolist() == env.robot_headings.tolist()
    events = output["events"]
    if assignment == "roundrobin":  # 2023: per robot, [task, step, "assigned" | "finished"]
        assert len(events) == 6
        finished = [e for robot in events for e in robot if e[2] == "finished"]
        assert len(finished) == env.errands.errands_done
        assert all(len(task) == 3 for task in output["tasks"])
    else:  # 2024: [step, robot, task, errands done], schedules per robot
        assert len(events) == env.errands.errands_done
        assert all(1 <= step <= STEPS and seq in (1, 2) for step, _, _, seq in events)
        assert all(len(task[2]) == 4 for task in output["tasks"])  # two stops: r, c, r, c
        assert len(output["actualSchedule"]) == 6
        assert output["numPlannerErrors"] == 0
    assert list(output) == [key for key, _ in output_json(env.instance, record, env.errands)]


def test_the_replay_finds_a_conflict_a_swap_and_a_move_into_a_shelf():
    env, _record = recorded_run("roundrobin", "grid")
    output = {"actionModel": "MAPF", "teamSize": 2, "start": [[0, 0, "E"], [0, 1, "E"]],
              "actualPaths": ["R,W,U", "L,W,W"]}  # fmt: skip
    walked = replay(output, env.grid)
    assert [what for *_, what in walked.conflicts] == ["edge conflict", "unallowed move"]
    output["actualPaths"] = ["R", "W"]
    assert [what for *_, what in replay(output, env.grid).conflicts] == ["vertex conflict"]
    with pytest.raises(ValueError, match="unknown actions"):
        replay({**output, "actualPaths": ["X", "W"]}, env.grid)


def test_a_refused_move_is_an_error_and_the_taken_action_a_wait():
    record = RunRecord(2, turning=True)
    record.add(np.array([0, 1]), np.array([3, 1]), np.array([True, False]), 0.5)
    assert record.errors == [(1, 0, 0, "move refused")]
    assert list(record.paths("actual")) == ["W", "R"]
    assert list(record.paths("planned")) == ["F", "R"]
    assert record.busy_steps.tolist() == [1, 0]


def test_a_run_on_ticks_writes_its_ticks_and_delays_and_replays_tick_by_tick(tmp_path):
    """One letter a tick, a move's on the tick it ends: the replay ends where the executor's
    robots stand, without a conflict; agentMaxCounter and delayIntervals follow teamSize."""
    from warehouse_phys.apps.simulate.on_ticks import simulate_ticks
    from warehouse_phys.envs import async_fleet
    from warehouse_phys.execution.delays import DelayConfig

    delays = DelayConfig(3, 1, 6, "bernoulli", 0.05, "uniform")
    instance = small_instance("scheduler", robots=6)
    env = async_fleet.parallel_env(instance=instance, ticks_per_move=3, delays=delays,
                                   record_errands=True)  # fmt: skip
    record = RunRecord(6, turning=False)
    result, _ = simulate_ticks(env, steps=STEPS, record=record)
    intervals = env.execution.delays.intervals_json()
    assert any(intervals)
    options = result.lorr_output_options()
    path = write_output(tmp_path / "out.json", env.instance, record, env.errands, **options)
    output = json.loads(path.read_text())
    assert list(output)[2:5] == ["teamSize", "agentMaxCounter", "delayIntervals"]
    assert output["agentMaxCounter"] == 3
    assert output["delayIntervals"] == intervals
    assert len(output["plannerTimes"]) == result.plans == -(-STEPS // 3)  # one a plan, not a tick
    walked = replay(output, env.grid)
    assert walked.conflicts == []
    assert walked.cells[-1].tolist() == env.execution.executor.left.tolist()
    with pytest.raises(ValueError, match="one list a robot"):
        output_json(env.instance, record, env.errands, agent_max_counter=3, delay_intervals=[[]])
