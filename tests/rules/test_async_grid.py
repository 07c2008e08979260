"""The grid twin of asynchronous execution: robots between cells, and the conflict checks
that the executor's tests rely on (they must see a conflict when there is one)."""

import pytest

from warehouse_phys.rules.async_grid import AsyncGrid, swap_conflicts, vertex_conflicts
from warehouse_phys.rules.grid import WarehouseGrid

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
