"""DistanceMaps: the grid's own breadth-first distances, for many goals at once, bounded."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.planners.distances import UNREACHABLE, DistanceMaps
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import PRESETS, resolve_layout


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


def test_a_request_for_more_goals_than_fit_builds_what_fits_and_guides_the_rest():
    grid = WarehouseGrid.from_layout(["S...#", ".....", ".....", "....."])
    maps = DistanceMaps(grid, max_bytes=3 * 2 * 20)
    maps.prepare(np.array([6, 7]))
    cells = np.array([0, 0, 0, 0])
    goals = np.array([1, 2, 3, 5])
    got = maps.lookup(cells, goals)
    assert maps.maps == 3
    assert maps.guided == 1
    assert maps.nbytes <= maps.max_bytes
    np.testing.assert_array_equal(got, _expected(grid, cells, goals))  # open ground: exact


def _star(grid: WarehouseGrid, cell: int) -> np.ndarray:
    """A robot's cell's four neighbours (itself where a move is blocked), then the cell: the
    cells a planner asks about."""
    row, col = divmod(cell, grid.cols)
    return np.array([grid.move((row, col), a)[0] * grid.cols + grid.move((row, col), a)[1]
                     for a in range(4)] + [cell])  # fmt: skip


@settings(max_examples=60, deadline=None)
@given(
    rows=st.integers(3, 12),
    cols=st.integers(3, 12),
    density=st.floats(0.0, 0.35),
    seed=st.integers(0, 2**32 - 1),
)
def test_guided_goals_walk_their_robots_home_on_upper_bounds_of_the_right_parity(
    rows, cols, density, seed
):
    """With room for one map, a fleet's goals are guided: every answer is at least the true
    distance and has its parity; the robot's own cell is answered within the guide path's
    weight; the best neighbour is one move closer; and a robot that always takes the best
    neighbour reaches its goal in the moves first answered."""
    rng = np.random.default_rng(seed)
    shelves = rng.random((rows, cols)) < density
    shelves[0, 0] = False
    layout = ["".join("#" if s else "." for s in row) for row in shelves]
    try:
        grid = WarehouseGrid.from_layout(layout)
    except ValueError:
        return
    free = _free_cells(grid)
    maps = DistanceMaps(grid, max_bytes=2 * (len(free) + 1))
    if len(free) < 5:
        return
    robots = rng.choice(free, size=4)
    goals = rng.choice(free, size=5, replace=False)  # one goal a robot: each its own group
    maps.prepare(goals[4:])
    goals = goals[:4]
    stars = np.stack([_star(grid, int(cell)) for cell in robots])
    targets = np.repeat(goals[:, None], 5, axis=1)
    got = maps.lookup(stars, targets)
    truth = _expected(grid, stars.ravel(), targets.ravel()).reshape(stars.shape)
    reachable = truth < UNREACHABLE
    assert (got == UNREACHABLE).tolist() == (~reachable).tolist()
    assert (got[reachable] >= truth[reachable]).all()
    assert ((got[reachable] - truth[reachable]) % 2 == 0).all()
    here, here_truth = got[:, 4], truth[:, 4]
    assert (here[reachable[:, 4]] <= np.ceil(here_truth[reachable[:, 4]] * 17 / 16)).all()
    for i in np.flatnonzero(reachable[:, 4] & (here > 0)).tolist():
        assert got[i, :4].min() == here[i] - 1
        cell, moves = int(robots[i]), int(here[i])
        for _ in range(moves):  # follow the best neighbour home: the answers count down
            star = _star(grid, cell)
            answers = maps.lookup(star, np.full(5, goals[i]))
            assert answers[4] == moves
            cell, moves = int(star[np.argmin(answers[:4])]), moves - 1
        assert cell == goals[i]


def test_a_guided_robot_pushed_off_its_path_gets_a_new_one_and_single_distances_leave_it():
    grid = resolve_layout("aisles")
    free = _free_cells(grid)
    maps = DistanceMaps(grid, max_bytes=2 * (len(free) + 1))
    mapped, goal, robot = int(free[0]), int(free[-1]), int(free[len(free) // 2])

    def ask(cells: np.ndarray) -> np.ndarray:
        """Look up cells towards the guided goal beside one query for the mapped one, which
        takes the room of the one map (the lower goal gets the room)."""
        goals = np.array([mapped, *[goal] * len(cells)])
        return maps.lookup(np.array([robot, *cells]), goals)[1:]

    first = ask(_star(grid, robot))
    assert maps.maps == 1
    assert maps.guided == 1
    slot = maps._slot_of_goal[goal]
    path = maps._pool[maps._path_start[slot] : maps._path_start[slot] + first[4] + 1].copy()
    assert path[0] == maps._column[robot]
    # Pushed one move aside: the path rejoins the old one where it passes beside.
    cols = grid.cols
    cell_of = np.flatnonzero(maps._column < maps._n_free)  # column -> cell
    on_path = set(cell_of[path].tolist())
    aside = next(c for c in _star(grid, robot)[:4].tolist()
                 if c != robot and c not in on_path)  # fmt: skip
    searches = []
    search = maps._path_from
    maps._path_from = lambda *args: searches.append(args) or search(*args)
    moves = ask(_star(grid, aside))[4]
    assert searches == []  # no search: the old path, rejoined
    maps._path_from = search
    spliced = maps._pool[maps._path_start[slot] : maps._path_start[slot] + moves + 1]
    assert cell_of[spliced[0]] == aside
    tail = cell_of[spliced[1:]].tolist()
    assert tail == cell_of[path[len(path) - len(tail) :]].tolist()
    assert abs(tail[0] // cols - aside // cols) + abs(tail[0] % cols - aside % cols) == 1
    path = spliced.copy()
    far = int(free[3])
    truth = _expected(grid, np.array([far]), np.array([goal]))[0]
    assert truth <= maps.distance(far, goal) <= np.ceil(truth * 17 / 16)  # a search of its own
    again = maps._pool[maps._path_start[slot] : maps._path_start[slot] + len(path)]
    np.testing.assert_array_equal(again, path)  # the robot's path stays
    aside = ask(_star(grid, far))  # the robot is now far away: a new path from there
    assert aside[4] == maps.distance(far, goal)
    assert maps._path_moves[slot] == aside[4]
    assert maps._pool[maps._path_start[slot]] == maps._column[far]


def test_the_guide_paths_memory_follows_the_fleet_not_every_goal_it_had():
    rng = np.random.default_rng(0)
    shelves = rng.random((60, 60)) < 0.2
    shelves[0, 0] = False
    grid = WarehouseGrid.from_layout(["".join("#" if s else "." for s in r) for r in shelves])
    free = np.array(sorted(r * 60 + c for r, c in grid.reachable))
    maps = DistanceMaps(grid, max_bytes=2 * (len(_free_cells(grid)) + 1))
    robots = rng.choice(free, size=8)
    longest = 0
    for _ in range(2000):  # 2,000 requests, each with eight fresh goals: 16,000 goals
        goals = rng.choice(free, size=8)
        longest = max(longest, int(maps.lookup(robots, goals).max()))
    recent = 8 * 64  # the goals of the last GUIDE_STALE_REQUESTS requests
    assert maps.guided <= len(maps._slot_goal)
    assert len(maps._slot_goal) <= 2 * recent + 1024
    assert maps.path_bytes <= 4 * 4 * recent * (longest + 1) + 40 * (2 * recent + 1024)


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
    import warehouse_phys.planners.distances as distances

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


def test_landmarks_stand_in_the_largest_region_and_bound_every_distance_from_below():
    """An island of two cells beside a large region: every landmark lies in the region
    (an island's landmark would help no search), and the estimates they give never
    exceed the true distance."""
    from warehouse_phys.planners.graph_search import estimate

    layout = ["." * 12 for _ in range(9)] + ["#" * 12, "..#" + "#" * 9]
    grid = WarehouseGrid.from_layout(layout)
    maps = DistanceMaps(grid)
    landmarks = maps._choose_landmarks()
    largest = maps._region == np.argmax(np.bincount(maps._region))
    assert len(landmarks) == 16
    for row in landmarks:
        source = int(np.flatnonzero(row[:-1] == 0)[0])  # a landmark is 0 from itself
        assert largest[source]
    free = _free_cells(grid)[: 12 * 9]
    goal = int(free[-1])
    truth = _expected(grid, free, np.full_like(free, goal))
    for cell, true in zip(free.tolist(), truth.tolist(), strict=True):
        bound = estimate(int(maps._column[cell]), int(maps._column[goal]), maps._cell_row,
                         maps._cell_col, landmarks)  # fmt: skip
        assert bound <= true
