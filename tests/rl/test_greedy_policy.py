"""The greedy policy of a Q-table: its actions and values on every cell, and its
evaluation from the start against every target."""

import time

import gymnasium as gym
import numpy as np
import pytest

from tests.rl.test_qlearning import GRID_ID
from warehouse_phys import Action
from warehouse_phys.rl.greedy_policy import evaluate, greedy_action, greedy_actions, state_values
from warehouse_phys.rl.qlearning import QLearningConfig, new_q_table, train


@pytest.fixture(scope="module")
def trained():
    """The default run on the grid twin (about 0.2 s)."""
    env = gym.make(GRID_ID)
    return env, train(env, QLearningConfig())


# ------------------------------------------------------- policies and values
def test_trained_values_are_the_discounted_reward_of_the_shortest_path(trained):
    env, result = trained
    grid = env.unwrapped.grid
    target = (3, 4)
    values = state_values(result.q, target)
    actions = greedy_actions(result.q, target)
    assert values.shape == actions.shape == (4, 5)
    assert actions.dtype == np.int64
    assert actions[target] == -1  # the episode ends there: never updated
    for cell in np.ndindex(4, 5):
        if cell == target:
            continue
        d = grid.optimal_steps(cell, target)
        # gamma ** (d - 1): reward 1 on arrival, discounted once per step before it.
        assert values[cell] == pytest.approx(0.9 ** (d - 1), abs=1e-6)
        # Every greedy action steps one cell closer.
        assert grid.optimal_steps(grid.move(cell, Action(actions[cell])), target) == d - 1


def test_cells_never_updated_have_no_greedy_action():
    q = new_q_table(2, 3)
    q[0, 1, 1, 2] = [0.0, 0.5, 0.2, 0.0]
    q[1, 1, 1, 2] = [0.0, 0.0, -0.1, 0.0]  # updated, all non-positive: still a choice
    assert greedy_actions(q, (1, 2)).tolist() == [[-1, 1, -1], [-1, 0, -1]]
    assert state_values(q, (1, 2)).tolist() == [[0.0, 0.5, 0.0], [0.0, 0.0, 0.0]]


def test_policy_maps_refuse_a_target_off_the_grid_or_a_bad_table():
    with pytest.raises(ValueError, match=r"target \(2, 0\) is off the 2x3 grid"):
        greedy_actions(new_q_table(2, 3), (2, 0))
    with pytest.raises(ValueError, match=r"expected a Q-table of shape \(R, C, R, C, 4\)"):
        state_values(np.zeros((2, 3, 4)), (0, 0))


# ---------------------------------------------------------------- evaluation
def test_default_training_reaches_every_target_by_a_shortest_path(trained):
    env, result = trained
    evaluation = evaluate(env, result.q)
    assert len(evaluation.results) == 12
    assert {r.target for r in evaluation.results} == set(env.unwrapped.grid.target_cells)
    assert evaluation.all_optimal
    assert all(r.steps == r.target[0] + r.target[1] for r in evaluation.results)
    assert evaluation.summary() == "all 12 targets reached by a shortest path"


def test_evaluation_reports_targets_never_reached():
    env = gym.make(GRID_ID, max_episode_steps=50)
    evaluation = evaluate(env, new_q_table(4, 5))  # all zeros: LEFT against the wall for ever
    assert evaluation.reached == evaluation.optimal == 0
    assert not evaluation.all_optimal
    assert all(r.steps is None for r in evaluation.results)
    assert evaluation.table().splitlines()[1] == "(1, 1)          -        2  not reached"
    assert evaluation.summary() == "0 of 12 targets reached, 0 of them by a shortest path"


def detour_table(rows=4, cols=5):
    """A policy that always reaches the target the long way: along row 0 to the last
    column, down to the target's row, then left."""
    q = new_q_table(rows, cols)
    for r, c, tr, tc in np.ndindex(rows, cols, rows, cols):
        if r == 0 and c < cols - 1:
            best = Action.RIGHT
        elif r < tr:
            best = Action.DOWN
        elif c > tc:
            best = Action.LEFT
        else:
            best = Action.RIGHT
        q[r, c, tr, tc, best] = 1.0
    return q


def test_evaluation_counts_the_steps_of_a_detour():
    env = gym.make(GRID_ID)
    evaluation = evaluate(env, detour_table())
    assert evaluation.reached == 12
    by_target = {r.target: r for r in evaluation.results}
    for (tr, tc), result in by_target.items():
        assert result.steps == 4 + tr + (4 - tc)
        assert result.optimal_steps == tr + tc
        assert result.optimal is (tc == 4)
    assert evaluation.optimal == 3
    assert "(1, 1)          8        2  6 too many" in evaluation.table()
    assert evaluation.summary() == "12 of 12 targets reached, 3 of them by a shortest path"
    assert evaluation.to_json()["results"][0] == {"target": [1, 1], "steps": 8, "optimal_steps": 2}


def test_evaluation_refuses_a_table_for_another_grid(trained):
    _, result = trained
    with pytest.raises(ValueError, match=r"does not fit a 3x3 grid"):
        evaluate(gym.make(GRID_ID, grid_rows=3, grid_cols=3), result.q)


def step_by_step_evaluation(env, q, max_steps):
    """The evaluation as an agent plays it: reset on each target, step the environment."""
    results = []
    for target in env.unwrapped.grid.target_cells:
        obs, info = env.reset(options={"target": target})
        steps = None
        for step in range(1, max_steps + 1):
            obs, _, terminated, truncated, _ = env.step(greedy_action(q, obs))
            if terminated:
                steps = step
                break
            if truncated:
                break
        results.append((tuple(target), steps, int(info["optimal_steps"])))
    return results


@pytest.mark.parametrize("layout", [None, "maze"])
@pytest.mark.parametrize("seed", range(3))
def test_the_evaluation_equals_playing_every_target_step_by_step(layout, seed):
    kwargs = {"layout": layout} if layout else {"grid_rows": 4, "grid_cols": 5}
    env = gym.make("warehouse-robot-v0", **kwargs)
    rows, cols = env.unwrapped.grid.rows, env.unwrapped.grid.cols
    rng = np.random.default_rng(seed)
    q = rng.random((rows, cols, rows, cols, 4)) * (rng.random((rows, cols, rows, cols, 1)) < 0.7)
    if seed == 2:
        q = train(env, QLearningConfig(episodes=300, seed=seed)).q  # partly learned
    fast = evaluate(env, q, max_steps=60)
    expected = step_by_step_evaluation(env, q, 60)
    assert [(tuple(r.target), r.steps, r.optimal_steps) for r in fast.results] == expected


def test_the_evaluation_of_a_large_floor_is_bounded_by_its_size():
    env = gym.make("warehouse-robot-v0", grid_rows=60, grid_cols=60)
    stuck = np.zeros((60, 60, 60, 60, 4))  # greedy: LEFT into the wall for ever
    pacing = stuck.copy()  # RIGHT from even columns, LEFT from odd ones: (0, 0) <-> (0, 1)
    pacing[:, 0::2, ..., 2] = 1
    pacing[:, 1::2, ..., 0] = 1
    for q in (stuck, pacing):
        started = time.process_time()
        evaluation = evaluate(env, q)
        assert time.process_time() - started < 10  # was minutes: 43,200 steps per target
        assert evaluation.reached == 0
        assert len(evaluation.results) == 59 * 59


def test_evaluating_one_robot_leaves_the_fleets_compiled_searches_unloaded(run_python):
    """``train`` evaluates its table in every run: on a floor of shelves too, the single
    robot's shortest paths come from its floor's own search, not the fleets' compiled
    distance maps, whose loading (numba) cost every train process 0.75 s of CPU."""
    loaded = run_python(
        "import sys, gymnasium as gym, numpy as np, warehouse_phys\n"
        "from warehouse_phys.rl.greedy_policy import evaluate\n"
        "env = gym.make('warehouse-robot-v0', layout='maze')\n"
        "grid = env.unwrapped.grid\n"
        "q = np.zeros((grid.rows, grid.cols, grid.rows, grid.cols, 4))\n"
        "longest = max(r.optimal_steps for r in evaluate(env, q).results)\n"
        "print(longest > grid.cols, 'numba' in sys.modules)"
    )
    assert loaded.split() == ["True", "False"]
