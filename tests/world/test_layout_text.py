"""A floor drawn as text and the size of any floor: symbols, starts, package cells and
the one-line errors for what cannot be a floor."""

from collections import deque

import numpy as np
import pytest
from hypothesis import given

from tests.world.test_grid import MAZE, layouts
from warehouse_phys.world.grid import ACTION_DELTAS, WarehouseGrid


# ------------------------------------------------------------------ sizes
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


# ---------------------------------------------------------------- layouts
def test_layout_symbols_make_shelves_start_and_package_cells():
    grid = WarehouseGrid.from_layout(MAZE)
    assert (grid.rows, grid.cols) == (3, 5)
    assert grid.shelves == {(0, 2), (1, 2), (1, 4)}
    assert grid.start == (0, 0)
    assert grid.target_cells == ((2, 4),)
    assert grid.layout == tuple(MAZE)
    assert not grid.is_free((0, 2))
    assert grid.is_free((0, 3))
    assert not grid.is_free((3, 0))


def test_without_package_cells_every_reachable_floor_cell_but_the_start_may_hold_one():
    grid = WarehouseGrid.from_layout([".#.", ".#.", "..."])
    assert set(grid.target_cells) == {(1, 0), (2, 0), (2, 1), (2, 2), (1, 2), (0, 2)}
    enclosed = WarehouseGrid.from_layout(["..#.", "..#.", "###."])  # (0..2, 3) is an office
    assert set(enclosed.target_cells) == {(0, 1), (1, 0), (1, 1)}
    assert (0, 3) not in enclosed.reachable


def test_start_symbol_moves_the_start():
    grid = WarehouseGrid.from_layout(["#..", ".S.", "..."])
    assert grid.start == (1, 1)
    assert grid.start not in grid.target_cells


@pytest.mark.parametrize(
    ("layout", "error", "message"),
    [
        ([], TypeError, "non-empty list of strings"),
        ("....", TypeError, "a layout is a list of strings"),
        ([".." , 3], TypeError, "non-empty list of strings"),
        ([""], ValueError, "layout row 0 is empty"),
        (["...", ".."], ValueError, "row 1 has 2 cells, row 0 has 3"),
        (["..x", "..."], ValueError, r"unknown layout symbol 'x' at row 0, column 2"),
        (["S.#", "##S"], ValueError, r"start cells \[\(1, 2\)\] cannot be reached"),
        (["##", "##"], ValueError, "the layout has no floor: every cell is a shelf"),
        (["S#P", "##."], ValueError, r"package cells \[\(0, 2\)\] cannot be reached"),
        (["S#.", "#.."], ValueError, "leaves no cell for the package"),
        (["S"], ValueError, "leaves no cell for the package"),
    ],
)  # fmt: skip
def test_invalid_layouts_are_refused_with_the_reason(layout, error, message):
    with pytest.raises(error, match=message):
        WarehouseGrid.from_layout(layout)


# ------------------------------------------------------------------ size limits
@pytest.mark.parametrize(
    ("rows", "cols", "error", "message"),
    [
        (2049, 4, ValueError, "grid_rows must be at most 2048, got 2049"),
        (4, 10**6, ValueError, "grid_cols must be at most 2048"),
        (2**63, 2**63, ValueError, "grid_rows must be at most 2048"),
        (np.int64(3000), 4, ValueError, "grid_rows must be at most 2048"),
        ("7", 4, TypeError, "grid_rows must be an integer"),
    ],
)
def test_sizes_beyond_the_largest_floor_are_refused(rows, cols, error, message):
    with pytest.raises(error, match=message):
        WarehouseGrid(rows, cols)


def test_layouts_beyond_the_largest_floor_are_refused():
    with pytest.raises(ValueError, match="the layout has 2049 rows of 2 cells"):
        WarehouseGrid.from_layout(["S."] + [".."] * 2048)


# ----------------------------------------------------------------- starts
def test_a_layout_may_hold_several_starts_for_a_fleet():
    grid = WarehouseGrid.from_layout(["S.S.", "....", "S..P"])
    assert grid.start == (0, 0)
    assert grid.starts == ((0, 0), (0, 2), (2, 0))
    assert grid.target_cells == ((2, 3),)
    plain = WarehouseGrid.from_layout(["S.S", "..."])  # no P: every reachable cell but the starts
    assert (0, 2) not in plain.target_cells
    assert plain.target_cells == ((0, 1), (1, 0), (1, 1), (1, 2))
    assert WarehouseGrid(3, 3).starts == ((0, 0),)


def test_a_given_start_is_marked_and_a_chosen_one_is_not():
    assert WarehouseGrid(3, 4).starts_marked
    assert WarehouseGrid.from_layout(["S.", ".."]).starts_marked
    corner = WarehouseGrid.from_layout(["..", ".."])
    assert not corner.starts_marked
    assert corner.start == (0, 0)
    assert corner.starts == ((0, 0),)
    assert (0, 0) not in corner.target_cells


@pytest.mark.parametrize(
    ("layout", "start"),
    [
        (["#.", ".."], (0, 1)),  # the corner is a shelf
        ([".#...", "##...", "#...."], (0, 2)),  # the corner is walled into one cell
        (["..#..", "..#.."], (0, 0)),  # two regions of 4: the first
        (["P.#....", "..#...."], (0, 1)),  # the package's region, not on the package
        (["PP#..", "###.."], (0, 0)),  # a region of packages only: its first cell
    ],
)  # fmt: skip
def test_without_a_start_the_robot_begins_in_the_largest_region(layout, start):
    grid = WarehouseGrid.from_layout(layout)
    assert grid.start == start
    assert not grid.starts_marked
    assert grid.start not in grid.target_cells


def _regions(layout):
    """An independent oracle: the free regions by flood fill, in reading order."""
    seen, regions = set(), []
    for r, row in enumerate(layout):
        for c, symbol in enumerate(row):
            if symbol == "#" or (r, c) in seen:
                continue
            region, queue = [], deque([(r, c)])
            seen.add((r, c))
            while queue:
                cell = queue.popleft()
                region.append(cell)
                for dr, dc in ACTION_DELTAS:
                    nr, nc = cell[0] + dr, cell[1] + dc
                    inside = 0 <= nr < len(layout) and 0 <= nc < len(row)
                    if inside and layout[nr][nc] != "#" and (nr, nc) not in seen:
                        seen.add((nr, nc))
                        queue.append((nr, nc))
            regions.append(sorted(region))
    return regions


@given(layouts())
def test_the_chosen_start_is_the_first_cell_of_the_first_largest_region(layout):
    grid = WarehouseGrid.from_layout(layout)
    regions = _regions(layout)
    largest = max(len(region) for region in regions)
    first = next(region for region in regions if len(region) == largest)
    assert grid.start == first[0]
    assert grid.reachable == set(first)


def test_long_lists_of_cells_in_layout_errors_are_cut_short():
    rows = ["S" + "." * 39, "#" * 40, "P" * 40]
    with pytest.raises(
        ValueError, match=r"\[\(2, 0\), .*\(2, 4\), \.\.\. \(40 in all\)\]"
    ) as error:
        WarehouseGrid.from_layout(rows)
    assert len(str(error.value)) < 200
