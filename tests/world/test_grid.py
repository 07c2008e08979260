"""The pure world model: actions, moves, target cells and sampling, optimal distances."""

import ast
import json
import subprocess
import sys
import textwrap
from collections import deque
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from tests.memory import CAN_MEASURE
from warehouse_phys import grid as grid_module
from warehouse_phys.world.grid import (
    ACTION_DELTAS,
    START_CELL,
    TARGET_REWARD,
    Action,
    Cell,
    WarehouseGrid,
    step_reward,
)
from warehouse_phys.world.layout_text import MAX_SIDE

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


def test_step_reward_rewards_only_arrival_less_the_penalties():
    assert step_reward(True) == TARGET_REWARD == 1.0
    assert step_reward(False) == 0.0
    assert step_reward(False, True) == 0.0  # a bump costs nothing without a penalty
    assert step_reward(False, True, 0.1, 0.5) == -0.6
    assert step_reward(True, False, 0.1, 0.5) == 1.0  # no step penalty on arrival


def test_world_model_imports_no_simulation_or_gui_library():
    tree = ast.parse(Path(grid_module.__file__).read_text())
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            imported.add(node.module.split(".")[0])
    assert not imported & {"gymnasium", "gym", "pymunk", "pygame"}


# --------------------------------------------------------------------- layouts
@st.composite
def layouts(draw, max_rows=6, max_cols=7):
    """Random valid layouts: floor and shelves (about a third), start at (0, 0)."""
    rows = draw(st.integers(1, max_rows))
    cols = draw(st.integers(2 if rows == 1 else 1, max_cols))
    symbols = draw(st.lists(st.sampled_from("..#"), min_size=rows * cols, max_size=rows * cols))
    text = ["".join(symbols[r * cols : (r + 1) * cols]) for r in range(rows)]
    text[0] = "." + text[0][1:]
    try:
        WarehouseGrid.from_layout(text)
    except ValueError:
        assume(False)  # everything walled off: no cell for a package
    return text


MAZE = ["S.#..", "..#.#", "....P"]


@given(layouts(), st.data())
def test_moves_never_enter_a_shelf_or_leave_the_floor(layout, data):
    grid = WarehouseGrid.from_layout(layout)
    cell = data.draw(st.sampled_from(sorted(grid.reachable)))
    for action in Action:
        moved = grid.move(cell, action)
        d_row, d_col = grid_module.ACTION_DELTAS[action]
        wanted = (cell[0] + d_row, cell[1] + d_col)
        assert moved == (wanted if grid.is_free(wanted) else cell)
        assert moved in grid.reachable


@given(layouts(), st.data())
def test_optimal_steps_around_shelves_is_the_shortest_path(layout, data):
    grid = WarehouseGrid.from_layout(layout)
    cell = data.draw(st.sampled_from(sorted(grid.reachable)))
    target = data.draw(st.sampled_from(grid.target_cells))
    steps = grid.optimal_steps(cell, target)
    assert steps == _bfs_steps(grid, cell, target)
    assert steps >= abs(cell[0] - target[0]) + abs(cell[1] - target[1])


def test_optimal_steps_detours_around_shelves_and_refuses_unreachable_cells():
    grid = WarehouseGrid.from_layout(MAZE)
    assert grid.optimal_steps((0, 0), (2, 4)) == 6
    # Two columns apart, but the shelf at (0, 2) and (1, 2) makes it a walk round row 2.
    assert grid.optimal_steps((0, 1), (0, 3)) == 6
    office = WarehouseGrid.from_layout(["..#.", "..#.", "###."])
    with pytest.raises(ValueError, match=r"\(1, 1\) cannot be reached from \(0, 3\)"):
        office.optimal_steps((0, 3), (1, 1))


@given(sizes)
def test_empty_layout_is_the_empty_floor(size):
    rows, cols = size
    text = ["." * cols] + ["." + "P" * (cols - 1)] * (rows - 1)
    laid_out, plain = WarehouseGrid.from_layout(text), WarehouseGrid(rows, cols)
    assert laid_out.target_cells == plain.target_cells
    assert laid_out.start == plain.start
    for cell in [(r, c) for r in range(rows) for c in range(cols)]:
        for action in Action:
            assert laid_out.move(cell, action) == plain.move(cell, action)
        for target in plain.target_cells:
            assert laid_out.optimal_steps(cell, target) == plain.optimal_steps(cell, target)


def test_random_walk_finish_rate_is_exact():
    grid = WarehouseGrid(4, 5)
    assert grid.random_walk_finish_rate(200) == pytest.approx(0.98664, abs=1e-5)
    assert grid.random_walk_finish_rate(0) == 0.0
    # One step from the start onto the only target, half the time.
    corridor = WarehouseGrid.from_layout(["SP"])
    assert corridor.random_walk_finish_rate(1) == pytest.approx(0.25)
    assert corridor.random_walk_finish_rate(2) == pytest.approx(0.25 + 0.75 * 0.25)


def test_random_walk_finish_rate_agrees_with_simulated_walks():
    grid = WarehouseGrid.from_layout(MAZE)
    rng = np.random.default_rng(0)
    walks, finished = 4000, 0
    for _ in range(walks):
        target, cell = grid.sample_target(rng), grid.start
        for _ in range(20):
            cell = grid.move(cell, int(rng.integers(4)))
            if cell == target:
                finished += 1
                break
    assert finished / walks == pytest.approx(grid.random_walk_finish_rate(20), abs=0.025)


@given(layouts(), st.integers(0, 2**32 - 1))
def test_layout_targets_are_drawn_from_the_allowed_cells_only(layout, seed):
    grid = WarehouseGrid.from_layout(layout)
    rng = np.random.default_rng(seed)
    drawn = {grid.sample_target(rng) for _ in range(30)}
    assert drawn <= set(grid.target_cells)
    assert grid.start not in drawn
    assert not drawn & grid.shelves


def test_layout_targets_are_uniform():
    grid = WarehouseGrid.from_layout(["S.#..", "..#.#", "....."])
    rng = np.random.default_rng(0)
    n = len(grid.target_cells)
    counts = np.zeros(n)
    index = {cell: i for i, cell in enumerate(grid.target_cells)}
    for _ in range(n * 2000):
        counts[index[grid.sample_target(rng)]] += 1
    assert np.abs(counts / 2000 - 1).max() < 0.1


def test_the_largest_floor_is_built():
    grid = WarehouseGrid(MAX_SIDE, MAX_SIDE)
    assert len(grid.reachable) == MAX_SIDE**2
    assert grid.optimal_steps(grid.start, (MAX_SIDE - 1, MAX_SIDE - 1)) == 2 * MAX_SIDE - 2


def test_breadth_first_distances_match_a_plain_search_around_shelves():
    grid = WarehouseGrid.from_layout(["S..#....", ".#.#.##.", ".#...#..", ".####.#.", "......#P"])
    for cell in sorted(grid.reachable):
        assert grid.optimal_steps(cell, grid.target_cells[0]) == _bfs_steps(
            grid, cell, grid.target_cells[0]
        )


# ------------------------------------------------------------------ floors as arrays
def _bfs_map(grid, target):
    """An independent oracle: every cell's distance to ``target`` by a plain search."""
    rows = [["#" if cell in grid.shelves else "." for cell in row] for row in
            [[(r, c) for c in range(grid.cols)] for r in range(grid.rows)]]  # fmt: skip
    distances = [[-1] * grid.cols for _ in range(grid.rows)]
    distances[target[0]][target[1]] = 0
    queue = deque([target])
    while queue:
        row, col = queue.popleft()
        for dr, dc in ACTION_DELTAS:
            r, c = row + dr, col + dc
            inside = 0 <= r < grid.rows and 0 <= c < grid.cols
            if inside and rows[r][c] == "." and distances[r][c] < 0:
                distances[r][c] = distances[row][col] + 1
                queue.append((r, c))
    return distances


def test_shelves_and_reachable_cells_behave_as_the_frozensets_they_were():
    grid = WarehouseGrid.from_layout(["S.#.", ".##.", "...#", "#.#."])
    shelves = frozenset({(0, 2), (1, 1), (1, 2), (2, 3), (3, 0), (3, 2)})
    assert grid.shelves == shelves
    assert shelves == grid.shelves
    assert grid.shelves != shelves - {(0, 2)}
    assert list(grid.shelves) == sorted(shelves)  # row-major, as Cells
    assert all(isinstance(cell, Cell) for cell in grid.shelves)
    assert len(grid.shelves) == 6
    assert bool(grid.shelves)
    assert (0, 2) in grid.shelves
    assert Cell(1, 1) in grid.shelves
    assert (np.int64(3), np.int64(2)) in grid.shelves
    for stranger in [(-1, 2), (0, -2), (4, 0), (0, 4), (0, 2, 1), "ab", 3, None, (0.0, 2.0)]:
        assert stranger not in grid.shelves  # never wraps round, never raises
    assert grid.shelves & {(0, 2), (0, 0)} == {(0, 2)}
    assert {(0, 2), (0, 0)} - grid.shelves == {(0, 0)}
    assert isinstance(grid.shelves | set(), frozenset)
    assert grid.reachable.isdisjoint(grid.shelves)
    assert (1, 3) not in grid.reachable  # free, but walled off
    assert len(grid.reachable) == 7  # not (0, 3), (1, 3) or (3, 3)
    assert grid.reachable == WarehouseGrid.from_layout(grid.layout).reachable
    assert WarehouseGrid(3, 3).shelves == frozenset()
    assert not WarehouseGrid(3, 3).shelves


def test_target_cells_behave_as_the_tuple_they_were():
    grid = WarehouseGrid.from_layout(["S.#.", "..#P", "P..."])
    cells = ((1, 3), (2, 0))
    assert grid.target_cells == cells
    assert cells == grid.target_cells
    assert grid.target_cells != cells[:1]
    assert tuple(grid.target_cells) == cells
    assert list(grid.target_cells) == list(cells)
    assert grid.target_cells[0] == (1, 3)
    assert isinstance(grid.target_cells[-1], Cell)
    assert grid.target_cells[-1] == (2, 0)
    assert grid.target_cells[:1] == ((1, 3),)
    with pytest.raises(IndexError):
        grid.target_cells[2]
    assert (2, 0) in grid.target_cells
    assert (0, 0) not in grid.target_cells
    assert (-1, 3) not in grid.target_cells
    assert "x" not in grid.target_cells
    assert grid.target_cells.index((2, 0)) == 1
    assert grid.target_cells.count((2, 0)) == 1
    with pytest.raises(ValueError, match="not in the sequence"):
        grid.target_cells.index((0, 1))
    assert np.asarray(grid.target_cells).tolist() == [[1, 3], [2, 0]]
    assert np.array(grid.target_cells, dtype=np.int64).reshape(-1, 2).shape == (2, 2)
    assert grid.target_cells.indices.tolist() == [7, 8]
    assert WarehouseGrid(3, 3).target_cells == ((1, 1), (1, 2), (2, 1), (2, 2))


def test_the_arrays_are_the_views_and_read_only():
    grid = WarehouseGrid.from_layout(["S.#.", ".##.", "..P#", "#.#."])
    assert grid.free_mask.shape == grid.shelf_mask.shape == grid.reachable_mask.shape == (4, 4)
    assert (grid.free_mask == ~grid.shelf_mask).all()
    assert {tuple(c) for c in np.argwhere(grid.shelf_mask)} == set(grid.shelves)
    assert {tuple(c) for c in np.argwhere(grid.reachable_mask)} == set(grid.reachable)
    assert grid.target_indices.dtype == np.int64
    assert grid.target_indices.tolist() == [r * 4 + c for r, c in grid.target_cells]
    for values in (grid.free_mask, grid.shelf_mask, grid.reachable_mask, grid.target_indices):
        with pytest.raises(ValueError, match="read-only"):
            values[0] = 0


def test_copies_and_pickles_keep_the_floor_and_its_arrays_read_only():
    import copy
    import pickle

    grid = WarehouseGrid.from_layout(["S.#.", ".##.", "...P"])
    grid.optimal_steps((0, 0), (2, 3))  # a cached distance map goes along
    for again in (copy.deepcopy(grid), pickle.loads(pickle.dumps(grid))):
        assert again.shelves == grid.shelves
        assert again.reachable == grid.reachable
        assert again.target_cells == grid.target_cells
        assert again.optimal_steps((0, 1), (2, 3)) == grid.optimal_steps((0, 1), (2, 3))
        assert not again.free_mask.flags.writeable
        assert not again.shelves.mask.flags.writeable


@given(layouts(), st.integers(0, 2**32 - 1), st.data())
def test_excluding_a_cell_draws_as_the_list_without_it_did(layout, seed, data):
    grid = WarehouseGrid.from_layout(layout)
    exclude = data.draw(st.sampled_from([*grid.target_cells, (0, 0), (-1, 5)]))
    rest = tuple(cell for cell in grid.target_cells if cell != exclude)
    assume(rest)
    ours, theirs = np.random.default_rng(seed), np.random.default_rng(seed)
    for _ in range(5):  # the rule before the floor was arrays: one draw from the rest
        assert grid.sample_target(ours, exclude) == rest[int(theirs.integers(len(rest)))]


@given(layouts(), st.data())
def test_distance_maps_match_a_plain_search_on_every_cell(layout, data):
    grid = WarehouseGrid.from_layout(layout)
    target = data.draw(st.sampled_from(sorted(grid.reachable)))
    expected = _bfs_map(grid, target)
    assert grid.distance_map(target) == expected
    assert grid.distance_array(target).tolist() == expected
    assert grid.distance_array(target).dtype == np.int32


def test_an_open_floors_distance_array_is_manhattan():
    grid = WarehouseGrid(3, 4)
    assert grid.distance_array((1, 2)).tolist() == [[3, 2, 1, 2], [2, 1, 0, 1], [3, 2, 1, 2]]


def test_distance_maps_of_a_large_maze_are_breadth_first_on_every_cell():
    rng = np.random.default_rng(1)
    walls = rng.random((1024, 1024)) < 0.2
    walls[0, 0] = False
    grid = WarehouseGrid.from_layout(["".join("#" if w else "." for w in row) for row in walls])
    distances = grid.distance_array(grid.start)
    assert (distances[~grid.reachable_mask] == -1).all()
    # Every reached cell but the start is one move further than its nearest neighbour.
    framed = np.pad(np.where(distances < 0, 2**30, distances), 1, constant_values=2**30)
    nearest = np.minimum.reduce(
        [framed[:-2, 1:-1], framed[2:, 1:-1], framed[1:-1, :-2], framed[1:-1, 2:]]
    )
    reached = grid.reachable_mask.copy()
    reached[grid.start] = False
    assert (distances[reached] == nearest[reached] + 1).all()
    assert distances[grid.start] == 0
    assert grid.optimal_steps((0, 0), grid.target_cells[-1]) == distances[grid.target_cells[-1]]


# Builds a 2,048 x 2,048 floor with 10 % shelves in a fresh process and prints the peak
# resident memory the build added (Linux's peak counter, reset just before) and its time.
PEAK_OF_BUILDING = textwrap.dedent(
    """
    import gc, json, time
    import numpy as np
    from warehouse_phys.world.grid import WarehouseGrid
    from warehouse_phys.world.layout_text import MAX_SIDE

    def status(field):
        with open("/proc/self/status") as lines:
            for line in lines:
                if line.startswith(field + ":"):
                    return int(line.split()[1]) * 1024

    WarehouseGrid.from_layout(["S.", ".#"])  # imports and first calls before the measuring
    shelves = np.random.default_rng(0).random((MAX_SIDE, MAX_SIDE)) < 0.1
    shelves[0, 0] = False
    symbols = np.where(shelves, ord("#"), ord(".")).astype(np.uint8)
    rows = [row.tobytes().decode("ascii") for row in symbols]
    del shelves, symbols
    gc.collect()
    with open("/proc/self/clear_refs", "w") as clear:
        clear.write("5")
    before = status("VmRSS")
    began = time.process_time()
    grid = WarehouseGrid.from_layout(rows)
    seconds = time.process_time() - began
    print(json.dumps({"peak": status("VmHWM") - before, "held": status("VmRSS") - before,
                      "seconds": seconds, "cells": grid.rows * grid.cols}))
    """
)


@pytest.mark.skipif(not CAN_MEASURE, reason="resident memory is read from Linux's /proc")
def test_the_largest_floor_builds_in_little_memory_per_cell():
    """Before the floor was arrays, a 2,048 x 2,048 floor took about 220 bytes a cell
    (Python objects for every cell) and 17 s; now about 18 bytes and 0.3 s."""
    result = subprocess.run(
        [sys.executable, "-c", PEAK_OF_BUILDING], capture_output=True, text=True,
        timeout=120, check=True,
    )  # fmt: skip
    figures = json.loads(result.stdout)
    assert figures["cells"] == MAX_SIDE**2 == 2048**2
    assert figures["peak"] / figures["cells"] < 32, figures  # bytes a cell, at the peak
    assert figures["held"] / figures["cells"] < 24, figures  # bytes a cell, kept
    assert figures["seconds"] < 5, figures
