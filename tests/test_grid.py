"""The pure world model: actions, moves, target cells and sampling, optimal distances."""

import ast
from collections import deque
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from warehouse_phys import grid as grid_module
from warehouse_phys.grid import START_CELL, Action, Cell, WarehouseGrid

sizes = st.tuples(st.integers(2, 12), st.integers(2, 12))


@st.composite
def grid_and_cell(draw):
    rows, cols = draw(sizes)
    cell = (draw(st.integers(0, rows - 1)), draw(st.integers(0, cols - 1)))
    return WarehouseGrid(rows, cols), cell


def test_action_values_are_the_documented_ones():
    assert [(a.name, a.value) for a in Action] == [
        ("LEFT", 0),
        ("DOWN", 1),
        ("RIGHT", 2),
        ("UP", 3),
    ]


def test_start_cell_is_top_left():
    assert START_CELL == (0, 0)


@given(grid_and_cell(), st.sampled_from(list(Action)))
def test_move_follows_the_rule_everywhere(grid_cell, action):
    grid, (row, col) = grid_cell
    d_row, d_col = {
        Action.LEFT: (0, -1),
        Action.DOWN: (1, 0),
        Action.RIGHT: (0, 1),
        Action.UP: (-1, 0),
    }[action]
    wanted = (row + d_row, col + d_col)
    if not (0 <= wanted[0] < grid.rows and 0 <= wanted[1] < grid.cols):
        wanted = (row, col)  # off the floor: stay put
    moved = grid.move((row, col), action)
    assert moved == wanted
    assert isinstance(moved, Cell)
    assert grid.contains(moved)


@given(sizes)
def test_target_cells_are_rows_and_columns_from_one(size):
    rows, cols = size
    grid = WarehouseGrid(rows, cols)
    assert len(grid.target_cells) == (rows - 1) * (cols - 1)
    assert set(grid.target_cells) == {(r, c) for r in range(1, rows) for c in range(1, cols)}
    assert START_CELL not in grid.target_cells


@given(sizes, st.integers(0, 2**32 - 1))
def test_sampled_target_is_always_an_allowed_cell(size, seed):
    grid = WarehouseGrid(*size)
    rng = np.random.default_rng(seed)
    for _ in range(20):
        row, col = grid.sample_target(rng)
        assert 1 <= row < grid.rows
        assert 1 <= col < grid.cols


@given(grid_and_cell(), st.integers(0, 2**32 - 1))
def test_sampled_target_avoids_the_excluded_cell(grid_cell, seed):
    grid, cell = grid_cell
    if set(grid.target_cells) <= {cell}:
        return  # a 2x2 grid whose only target cell is excluded: nothing to draw from
    rng = np.random.default_rng(seed)
    for _ in range(20):
        assert grid.sample_target(rng, exclude=cell) != cell


def test_excluding_the_default_start_leaves_the_draw_unchanged():
    grid = WarehouseGrid(4, 5)
    plain = [grid.sample_target(np.random.default_rng(3)) for _ in range(5)]
    excluded = [grid.sample_target(np.random.default_rng(3), exclude=START_CELL) for _ in range(5)]
    assert plain == excluded


def _bfs_steps(grid, start, goal):
    """An independent oracle: breadth-first search over the grid's moves."""
    seen = {tuple(start): 0}
    queue = deque([tuple(start)])
    while queue:
        cell = queue.popleft()
        if cell == tuple(goal):
            return seen[cell]
        for action in Action:
            nxt = tuple(grid.move(cell, action))
            if nxt not in seen:
                seen[nxt] = seen[cell] + 1
                queue.append(nxt)
    raise AssertionError("goal unreachable")


@given(grid_and_cell(), st.data())
def test_optimal_steps_equals_shortest_path(grid_cell, data):
    grid, cell = grid_cell
    target = data.draw(st.sampled_from(grid.target_cells))
    assert grid.optimal_steps(cell, target) == _bfs_steps(grid, cell, target)


def test_outcome_rewards_only_the_target_cell():
    assert WarehouseGrid.outcome((2, 3), (2, 3)) == (1.0, True)
    assert WarehouseGrid.outcome((2, 2), (2, 3)) == (0.0, False)
    assert WarehouseGrid.outcome((3, 2), (2, 3)) == (0.0, False)


@pytest.mark.parametrize(("rows", "cols"), [(1, 5), (4, 1), (0, 0), (-3, 5), (1, 1)])
def test_too_small_grid_is_refused_with_the_reason(rows, cols):
    with pytest.raises(ValueError, match=r"at least 2.*rows 1\.\.R-1 and columns 1\.\.C-1"):
        WarehouseGrid(rows, cols)


@pytest.mark.parametrize("bad", [2.0, "4", None, True])
def test_non_integer_grid_size_is_refused(bad):
    with pytest.raises(TypeError, match="grid_rows must be an integer"):
        WarehouseGrid(bad, 5)


def test_numpy_integer_sizes_are_accepted():
    grid = WarehouseGrid(np.int64(3), np.int32(4))
    assert (grid.rows, grid.cols) == (3, 4)
    assert type(grid.rows) is int


def test_world_model_imports_no_simulation_or_gui_library():
    tree = ast.parse(Path(grid_module.__file__).read_text())
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            imported.add(node.module.split(".")[0])
    assert not imported & {"gymnasium", "gym", "pymunk", "pygame"}
