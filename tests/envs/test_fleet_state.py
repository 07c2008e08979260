"""A fleet's robots as arrays: the packages placed at a reset and drawn on delivery, never
on a robot or another robot's package, uniform over the cells left to each, drawn at
once as they would be one robot at a time."""

import copy

import numpy as np
import pytest

from warehouse_phys.envs import fleet


def test_packages_are_never_on_a_robot_or_another_robots_package():
    env = fleet.parallel_env(num_robots=4, grid_rows=4, grid_cols=5)
    grid = env.grid
    for seed in range(200):
        env.reset(seed=seed)
        state = env.state().reshape(4, 4)
        packages = {tuple(p) for p in state[:, 2:]}
        assert len(packages) == 4
        assert not packages & {tuple(c) for c in state[:, :2]}
        assert packages <= set(grid.target_cells)


def drawn_in_turn(env, robots, rng):
    """New packages for ``robots`` drawn one robot at a time (the rule's plain statement)."""
    cols, packages = env.grid.cols, env.package_cells.copy()
    taken = np.zeros(env.grid.rows * cols, dtype=bool)
    taken[env.robot_cells @ [cols, 1]] = True
    keep = np.ones(env.num_robots, dtype=bool)
    keep[robots] = False
    taken[packages[keep] @ [cols, 1]] = True
    targets = np.array([r * cols + c for r, c in env.grid.target_cells])
    for robot in robots:
        for _ in range(8):
            cell = targets[rng.integers(len(targets))]
            if not taken[cell]:
                break
        else:
            free = targets[~taken[targets]]
            cell = free[rng.integers(len(free))]
        taken[cell] = True
        packages[robot] = divmod(int(cell), cols)
    return packages


@pytest.mark.parametrize(("n", "side"), [(6, 4), (40, 12)])
def test_new_packages_drawn_at_once_are_those_drawn_in_turn(n, side):
    env = fleet.parallel_env(num_robots=n, grid_rows=side, grid_cols=side + 1, lifelong=True)
    env.reset(seed=n)
    choose = np.random.default_rng(0)
    for _ in range(40):
        robots = np.sort(choose.choice(n, size=int(choose.integers(1, n + 1)), replace=False))
        in_turn = copy.deepcopy(env.np_random)
        expected = drawn_in_turn(env, robots.tolist(), in_turn)
        env._draw_new_packages(robots)
        assert np.array_equal(env.package_cells, expected)
        assert env.np_random.bit_generator.state == in_turn.bit_generator.state
        env.step(dict(zip(env.agents, choose.integers(5, size=n).tolist(), strict=True)))


def test_each_robots_package_is_uniform_over_the_cells_left_to_it():
    from tests.envs.test_vector import chi_square_uniform

    env = fleet.parallel_env(num_robots=2)
    targets = env.grid.target_cells  # the starts (0, 0) and (0, 1) are none of them
    counts = dict.fromkeys(targets, 0)
    for seed in range(3000):
        env.reset(seed=seed)
        counts[tuple(env.state()[2:4])] += 1  # robot_0 draws first, from every target cell
    statistic, bound = chi_square_uniform(list(counts.values()))
    assert statistic < bound
