"""The grid twin of asynchronous execution: robots between cells, and the conflict checks
that the executor's tests rely on (they must see a conflict when there is one)."""

import math

import numpy as np
import pytest

from warehouse_phys.execution.async_grid import (
    AsyncGrid,
    closest_squared,
    gap_conflicts,
    swap_conflicts,
    vertex_conflicts,
)
from warehouse_phys.world.grid import WarehouseGrid

GRID = WarehouseGrid.from_layout(["S..", ".#.", "..."])


def test_a_robot_in_mid_move_holds_both_cells_until_its_move_ends():
    world = AsyncGrid(GRID, [0], 3)
    assert world.step([True], [1]).tolist() == [False]
    assert world.held().tolist() == [[0, 1]]
    assert world.step([True], [1], [True]).tolist() == [False]  # delayed: holds
    assert world.step([False], [1]).tolist() == [False]  # STOP: holds
    assert world.done.tolist() == [1]
    assert world.step([True], [1]).tolist() == [False]
    assert world.step([True], [1]).tolist() == [True]
    assert world.held().tolist() == [[1, 1]]


def test_go_with_ones_own_cell_is_no_move():
    world = AsyncGrid(GRID, [0], 1)
    assert world.step([True], [0]).tolist() == [False]
    assert world.held().tolist() == [[0, 0]]
    assert world.done.tolist() == [0]


@pytest.mark.parametrize(("cells", "heading"), [([0], [4]), ([0], [2]), ([3], [4])])
def test_a_heading_that_is_not_a_move_is_refused(cells, heading):
    """Onto the shelf, two cells away, into the shelf from beside it."""
    world = AsyncGrid(GRID, cells, 1)
    with pytest.raises(ValueError, match="heading: robot 0"):
        world.step([True], heading)


def test_a_robot_in_mid_move_cannot_turn_back():
    world = AsyncGrid(GRID, [0], 2)
    world.step([True], [1])
    with pytest.raises(ValueError, match="cannot head for cell 0"):
        world.step([True], [0])


def test_the_checks_see_two_robots_in_one_cell_and_a_swap():
    world = AsyncGrid(GRID, [0, 2], [2, 1])
    world.step([True, True], [1, 1])  # robot 0 starts into cell 1, robot 1 enters it
    assert vertex_conflicts(world.held()).tolist() == [1]
    swapping = AsyncGrid(GRID, [0, 1], 1)
    before = swapping.held()
    swapping.step([True, True], [1, 0])
    assert vertex_conflicts(swapping.held()).size == 0
    assert swap_conflicts(before, swapping.held()) == 1


def test_a_follow_is_not_a_swap():
    world = AsyncGrid(GRID, [0, 1], 1)
    before = world.held()
    world.step([True, True], [1, 2])
    assert swap_conflicts(before, world.held()) == 0
    assert vertex_conflicts(world.held()).size == 0


def tick(world, go, heading):
    """Step ``world`` a tick; the held cells and centres before and after it."""
    held, centres = world.held(), world.centres()
    world.step(go, heading)
    return (held, world.held()), (centres, world.centres())


def test_centres_are_the_share_of_the_move_done():
    world = AsyncGrid(GRID, [0, 5], [4, 2])
    world.step([True, True], [1, 8])
    assert world.centres().tolist() == [[0.0, 0.25], [1.5, 2.0]]


def test_the_gap_check_sees_a_follower_close_in_and_robots_pass_through_each_other():
    line = AsyncGrid(GRID, [1, 0], 3)  # robot 1 behind robot 0, a cell apart
    assert gap_conflicts(*tick(line, [True, True], [2, 1]), min_gap=1.0) == 0
    held, centres = tick(line, [False, True], [2, 1])  # robot 1 closes in to 2/3 of a cell
    assert gap_conflicts(held, centres, min_gap=0.7) == 1
    assert gap_conflicts(held, centres, min_gap=0.6) == 0
    swapping = AsyncGrid(GRID, [0, 1], 1)  # a swap of one tick: apart at both ends, not between
    assert gap_conflicts(*tick(swapping, [True, True], [1, 0]), min_gap=0.1) == 1
    corner = AsyncGrid(GRID, [2, 1], 1)  # robot 0 goes down as robot 1 follows into cell 2
    held, centres = tick(corner, [True, True], [5, 2])
    assert gap_conflicts(held, centres, min_gap=math.sqrt(0.5)) == 0
    assert gap_conflicts(held, centres, min_gap=0.72) == 1


def test_the_closest_approach_of_linear_motions():
    start = np.array([[1.0, 0.0], [1.0, 0.0], [3.0, 4.0]])
    end = np.array([[-1.0, 0.0], [2.0, 0.0], [3.0, 4.0]])
    assert closest_squared(start, end).tolist() == [0.0, 1.0, 25.0]


def test_cells_off_the_floor_or_on_a_shelf_are_refused():
    for cells in ([4], [9], [-1]):
        with pytest.raises(ValueError, match="free cells"):
            AsyncGrid(GRID, cells, 1)
    with pytest.raises(ValueError, match="at least 1"):
        AsyncGrid(GRID, [0], 0)


def test_commands_must_be_one_a_robot():
    world = AsyncGrid(GRID, [0, 1], 1)
    with pytest.raises(ValueError, match="one entry per robot"):
        world.step([True], [1, 2])


def test_a_turning_robot_turns_in_place_a_quarter_at_a_time():
    world = AsyncGrid(GRID, [0], 2, headings=[0])
    assert world.step([True], [0], None, [1]).tolist() == [False]
    assert world.held().tolist() == [[0, 0]]
    assert world.done.tolist() == [1]
    assert world.step([True], [0], None, [1]).tolist() == [True]
    assert world.headings.tolist() == [1]
    with pytest.raises(ValueError, match="cannot turn from 1 to 3"):
        world.step([True], [0], None, [3])
    with pytest.raises(ValueError, match="facing"):
        world.step([True], [0])
