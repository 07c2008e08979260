"""The compiled searches: breadth-first maps and A* paths against the grid's own distances."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.planners.graph_search import (
    UNREACHABLE,
    estimate,
    fill_distance_rows,
    move_graph,
    shortest_path,
)
from warehouse_phys.world.grid import WarehouseGrid


def _floor(rows: int, cols: int, density: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A random floor's free mask and its cells' indices by column (free-cell rank)."""
    free = np.random.default_rng(seed).random((rows, cols)) >= density
    return free, np.flatnonzero(free.reshape(-1))


def _truth(free: np.ndarray, cells: np.ndarray, goal_column: int) -> np.ndarray:
    """The grid's own breadth-first distances from every free cell to the goal."""
    grid = WarehouseGrid.from_layout(["".join("." if f else "#" for f in row) for row in free])
    goal = divmod(int(cells[goal_column]), free.shape[1])
    distances = grid.distance_array(goal).reshape(-1)[cells]
    return np.where(distances < 0, UNREACHABLE, distances)


def _landmarks(neighbours: np.ndarray, count: int) -> np.ndarray:
    table = np.empty((count, len(neighbours) + 1), dtype=np.uint16)
    sources = np.linspace(0, len(neighbours) - 1, count).astype(np.int64)
    assert fill_distance_rows(neighbours, sources, table, np.arange(count)) == -1
    return table


@settings(max_examples=60, deadline=None)
@given(
    rows=st.integers(2, 14),
    cols=st.integers(2, 14),
    density=st.floats(0.0, 0.4),
    seed=st.integers(0, 2**32 - 1),
)
def test_maps_and_paths_are_the_grids_distances(rows, cols, density, seed):
    """Breadth-first maps equal the grid's distances; exact A* (with or without landmarks)
    finds paths of exactly that length, made of moves, from the source to the goal; a
    weighted A* finds one at most its weight longer; every estimate is a lower bound."""
    free, cells = _floor(rows, cols, density, seed)
    if len(cells) < 2:
        return
    try:
        truth = _truth(free, cells, 0)
    except ValueError:  # a floor the grid refuses (no room for a package)
        return
    neighbours = move_graph(free)
    table = np.empty((1, len(cells) + 1), dtype=np.uint16)
    assert fill_distance_rows(neighbours, np.array([0]), table, np.array([0])) == -1
    np.testing.assert_array_equal(table[0, :-1], truth)
    assert table[0, -1] == UNREACHABLE
    cell_row, cell_col = (a.astype(np.int32) for a in np.divmod(cells, cols))
    scratch = np.zeros((len(cells), 4), dtype=np.int32)
    path = np.empty(len(cells), dtype=np.int32)
    none = np.empty((0, len(cells) + 1), dtype=np.uint16)
    generation = 0
    for landmarks in (none, _landmarks(neighbours, min(3, len(cells)))):
        for source in range(len(cells)):
            for weight16 in (16, 24):
                generation += 1
                moves = shortest_path(neighbours, cell_row, cell_col, source, 0, scratch,
                                      generation, path, landmarks, weight16)  # fmt: skip
                if truth[source] == UNREACHABLE:
                    assert moves == -1
                    continue
                assert truth[source] <= moves <= truth[source] * weight16 / 16
                steps = path[: moves + 1]
                assert steps[0] == source
                assert steps[-1] == 0
                apart = np.abs(np.diff(cell_row[steps])) + np.abs(np.diff(cell_col[steps]))
                assert (apart == 1).all()
            if truth[source] != UNREACHABLE:
                assert estimate(source, 0, cell_row, cell_col, landmarks) <= truth[source]


def test_a_map_deeper_than_the_limit_is_reported_not_wrapped():
    free = np.ones((1, 12), dtype=bool)
    neighbours = move_graph(free)
    table = np.empty((2, 13), dtype=np.uint16)
    sources = np.array([0, 11])
    assert fill_distance_rows(neighbours, sources, table, np.arange(2), 12) == -1
    assert fill_distance_rows(neighbours, sources, table, np.arange(2), 11) == 0


@pytest.mark.parametrize("shape", [(1, 1), (3, 1), (1, 4)])
def test_the_move_graph_of_thin_floors(shape):
    neighbours = move_graph(np.ones(shape, dtype=bool))
    degree = (neighbours >= 0).sum(axis=1)
    assert degree.sum() == 2 * (max(shape) - 1)
