"""The field's measures of a fleet (sum of costs, makespan, throughput) and the baselines."""

import numpy as np
import pytest

from warehouse_phys.envs import fleet
from warehouse_phys.rl.fleet_evaluation import (
    compare_policies,
    evaluate_fleet,
    evaluate_throughput,
    random_fleet_policy,
    shortest_path_policy,
    walled_off_packages,
)
from warehouse_phys.world.traffic import WAIT


def always_wait(env, observations, infos):
    return dict.fromkeys(observations, WAIT)


def test_undelivered_robots_count_at_the_time_limit():
    env = fleet.parallel_env(num_robots=3, max_cycles=7)
    waiting = evaluate_fleet(env, always_wait, seeds=range(4))
    assert waiting.delivered == 0
    assert waiting.sum_of_costs == 4 * 3 * 7
    assert waiting.makespan == 7
    assert waiting.waits == 4 * 3 * 7
    assert waiting.deadlocks == 4
    assert waiting.all_shortest_steps > 0
    moving = evaluate_fleet(fleet.parallel_env(num_robots=3), shortest_path_policy)
    assert moving.sum_of_costs >= moving.all_shortest_steps
    assert moving.robot_steps <= moving.sum_of_costs
    assert moving.to_json()["undelivered"] == 60 - moving.delivered


def test_a_package_behind_a_parked_robot_counts_as_walled_off():
    env = fleet.parallel_env(num_robots=2, layout=["S#.", ".#.", "..."])
    env.reset(seed=0)
    env._cells = np.array([(0, 0), (2, 1)])
    env._packages = np.array([(0, 2), (2, 1)])
    env._parked[1] = True  # robot_1 parked in the only passage
    assert walled_off_packages(env) == 1
    env._parked[1] = False
    assert walled_off_packages(env) == 0


def test_throughput_is_deliveries_per_step_of_a_lifelong_fleet():
    env = fleet.parallel_env(num_robots=4, lifelong=True, max_cycles=100)
    result = evaluate_throughput(env, shortest_path_policy, steps=100, seeds=range(2))
    assert result.throughput == np.mean(result.deliveries) / 100 > 0
    assert result.to_json()["throughput"] == result.throughput
    with pytest.raises(ValueError, match="needs a lifelong fleet"):
        evaluate_throughput(fleet.parallel_env(), shortest_path_policy, steps=10)
    # evaluate_fleet measures a lifelong fleet by its throughput, over max_cycles steps.
    assert evaluate_fleet(env, shortest_path_policy, seeds=range(2)) == result
    with pytest.raises(ValueError, match="steps is for lifelong fleets"):
        evaluate_fleet(fleet.parallel_env(), shortest_path_policy, steps=10)


def test_the_comparison_says_when_a_policy_does_worse_than_a_baseline():
    env = fleet.parallel_env(num_robots=2, max_cycles=30)
    table = compare_policies(
        {
            "waiting": evaluate_fleet(env, always_wait, seeds=range(3)),
            "shortest": evaluate_fleet(env, shortest_path_policy, seeds=range(3)),
            "random": evaluate_fleet(env, random_fleet_policy(0), seeds=range(3)),
        }
    )
    assert table.splitlines()[0].startswith("waiting   0/6 packages delivered")
    assert "WORSE: waiting delivers fewer packages (0 < " in table
    assert "than shortest" in table
    assert "than random" in table


def test_the_shortest_path_baseline_takes_the_first_shortening_move_to_a_free_cell():
    env = fleet.parallel_env(num_robots=6, layout="aisles", starts="random", lifelong=True)
    rng = np.random.default_rng(0)
    observations, infos = env.reset(seed=3)
    grid = env.grid
    for _ in range(40):
        actions = shortest_path_policy(env, observations, infos)
        taken = {tuple(c) for c in env.robot_cells.tolist()}
        for agent, obs in observations.items():
            row, col, p_row, p_col = (int(v) for v in obs)
            here = grid.optimal_steps((row, col), (p_row, p_col))
            expected = WAIT
            for action in range(4):
                cell = grid.move((row, col), action)
                if tuple(cell) not in taken and grid.optimal_steps(cell, (p_row, p_col)) < here:
                    expected = action
                    break
            assert actions[agent] == expected
        moves = {a: int(rng.integers(5)) for a in env.agents}
        observations, _, _, _, infos = env.step(moves)
