"""DistanceMaps: the grid's own breadth-first distances, for many goals at once, bounded."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.rules.distances import UNREACHABLE, DistanceMaps
from warehouse_phys.rules.grid import WarehouseGrid
from warehouse_phys.rules.layouts import PRESETS, resolve_layout


def _expected(grid: WarehouseGrid, cells: np.ndarray, goals: np.ndarray) -> np.ndarray:
    out = []
    for cell, goal in zip(cells.tolist(), goals.tolist(), strict=True):
        d = grid.distance_map(divmod(goal, grid.cols))[cell // grid.cols][cell % grid.cols]
        out.append(UNREACHABLE if d < 0 else d)
    return np.array(out, dtype=np.int64)


def _free_cells(grid: WarehouseGrid) -> np.ndarray:
    return np.array(
        [r * grid.cols + c for r in range(grid.rows) for c in range(grid.cols)
         if grid.is_free((r, c))]
    )  # fmt: skip


@pytest.mark.parametrize("name", [None, *sorted(PRESETS)])
def test_every_cell_to_every_goal_equals_the_grids_distance_map(name):
    grid = WarehouseGrid(4, 5) if name is None else resolve_layout(name)
    maps = DistanceMaps(grid)
    goals = _free_cells(grid)
    cells = np.arange(grid.rows * grid.cols)
    all_cells = np.tile(cells, len(goals))
    all_goals = np.repeat(goals, len(cells))
    got = maps.lookup(all_cells, all_goals)
    assert got.dtype == np.int64
    np.testing.assert_array_equal(got, _expected(grid, all_cells, all_goals))


@settings(max_examples=40, deadline=None)
@given(
    rows=st.integers(2, 9),
    cols=st.integers(2, 9),
    shelf_bits=st.integers(0, 2**81 - 1),
    seed=st.integers(0, 2**32 - 1),
)
def test_random_floors_with_walled_off_regions(rows, cols, shelf_bits, seed):
    """Shelves anywhere, regions cut off from each other: unreachable cells and shelves read
    UNREACHABLE, every other cell the grid's distance."""
    layout = [
        "".join("#" if (shelf_bits >> (r * cols + c)) & 1 and (r, c) != (0, 0) else "."
                for c in range(cols))
        for r in range(rows)
    ]  # fmt: skip
    layout[0] = "S" + layout[0][1:]
    try:
        grid = WarehouseGrid.from_layout(layout)
    except ValueError:  # no room for a package: not a floor
        return
    maps = DistanceMaps(grid)
    rng = np.random.default_rng(seed)
    goals = rng.choice(_free_cells(grid), size=20)
    cells = rng.integers(rows * cols, size=20)
    np.testing.assert_array_equal(maps.lookup(cells, goals), _expected(grid, cells, goals))


def test_the_maps_never_exceed_max_bytes_and_the_least_recently_used_go_first():
    grid = resolve_layout("aisles")
    one_map = 2 * (grid.rows * grid.cols - len(grid.shelves) + 1)
    maps = DistanceMaps(grid, max_bytes=5 * one_map)
    free = _free_cells(grid)
    for goal in free[:5]:
        maps.prepare(np.array([goal]))
    assert maps.maps == 5
    maps.prepare(free[:1])  # the first goal used again: the second is now the oldest
    maps.prepare(free[5:6])
    assert maps.maps == 5
    assert maps.nbytes <= maps.max_bytes
    kept = set(maps._goal_of_row.tolist())
    assert free[1] not in kept
    assert free[0] in kept
    assert free[5] in kept
    # Evicted maps come back with the same numbers.
    cells = np.arange(grid.rows * grid.cols)
    goals = np.full_like(cells, free[1])
    np.testing.assert_array_equal(maps.lookup(cells, goals), _expected(grid, cells, goals))
    assert maps.nbytes <= maps.max_bytes


def test_a_request_for_more_goals_than_fit_is_refused_and_changes_nothing():
    grid = WarehouseGrid.from_layout(["S...#", ".....", ".....", "....."])
    maps = DistanceMaps(grid, max_bytes=3 * 2 * 20)
    maps.prepare(np.array([6, 7]))
    with pytest.raises(ValueError, match="max_bytes"):
        maps.prepare(np.array([1, 2, 3, 5]))
    assert sorted(g for g in maps._goal_of_row.tolist() if g >= 0) == [6, 7]


def test_bad_arguments_are_refused():
    grid = resolve_layout("maze")
    maps = DistanceMaps(grid)
    shelf = next(iter(grid.shelves))
    with pytest.raises(ValueError, match="is a shelf"):
        maps.lookup(np.array([0]), np.array([shelf[0] * grid.cols + shelf[1]]))
    with pytest.raises(ValueError, match="goals must be cell indices"):
        maps.lookup(np.array([0]), np.array([grid.rows * grid.cols]))
    with pytest.raises(ValueError, match="cells must be indices"):
        maps.lookup(np.array([-1]), np.array([1]))
    with pytest.raises(ValueError, match="differ in shape"):
        maps.lookup(np.array([0, 1]), np.array([1]))
    with pytest.raises(ValueError, match="max_bytes"):
        DistanceMaps(grid, max_bytes=4)
    with pytest.raises(TypeError, match="max_bytes"):
        DistanceMaps(grid, max_bytes=1.5e9)
    with pytest.raises(TypeError, match="WarehouseGrid"):
        DistanceMaps([".."])
    assert maps.lookup(np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)).shape == (0,)


def test_a_path_longer_than_sixteen_bits_is_refused_not_wrapped(monkeypatch):
    """The 16-bit guard, exercised on a small snake by pretending the limit is lower."""
    import warehouse_phys.rules.distances as distances

    grid = WarehouseGrid.from_layout(["S....", "####.", ".....", ".####", "....."])
    monkeypatch.setattr(distances, "UNREACHABLE", 10)
    maps = distances.DistanceMaps(grid)
    with pytest.raises(ValueError, match="16-bit"):
        maps.lookup(np.array([0]), np.array([24]))


def test_a_floor_without_shelves_needs_no_maps():
    grid = WarehouseGrid(30, 40)
    maps = DistanceMaps(grid)
    cells = np.arange(grid.rows * grid.cols)
    goals = np.full_like(cells, 5 * 40 + 7)
    np.testing.assert_array_equal(maps.lookup(cells, goals), _expected(grid, cells, goals))
    assert maps.maps == maps.nbytes == 0
    with pytest.raises(ValueError, match="goals must be cell indices"):
        maps.prepare(np.array([grid.rows * grid.cols]))


def test_one_distance_is_the_lookups():
    for grid in (resolve_layout("aisles"), WarehouseGrid(6, 7)):
        maps = DistanceMaps(grid)
        free = _free_cells(grid)
        cells = np.arange(grid.rows * grid.cols)
        for goal in free[:: max(1, len(free) // 5)].tolist():
            expected = maps.lookup(cells, np.full_like(cells, goal))
            assert [maps.distance(c, goal) for c in cells.tolist()] == expected.tolist()
