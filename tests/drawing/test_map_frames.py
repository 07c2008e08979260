"""Map frames: a fleet on a large floor drawn with array operations."""

import numpy as np
import pytest

from warehouse_phys.drawing import map_frames
from warehouse_phys.world.grid import WarehouseGrid


def test_map_colours_stay_apart_from_each_other_and_from_the_floor():
    colours = map_frames.MAP_ROBOT_COLOURS.astype(float)
    apart = np.linalg.norm(colours[:, None] - colours[None, :], axis=-1)
    np.fill_diagonal(apart, np.inf)
    assert len(colours) == 8
    assert apart.min() > 60
    marks = [map_frames.MAP_FLOOR, map_frames.MAP_SHELF, map_frames.MAP_PACKAGE,
             map_frames.MAP_DELIVERED]  # fmt: skip
    for mark in np.array(marks, dtype=float):
        assert np.linalg.norm(colours - mark, axis=-1).min() > 60
    background = np.array(marks[:3], dtype=float)  # floor, shelves, packages: apart too
    apart = np.linalg.norm(background[:, None] - background[None, :], axis=-1)
    np.fill_diagonal(apart, np.inf)
    assert apart.min() > 60


def test_a_500_by_140_floor_fits_1000_pixels_with_robots_as_squares_of_their_colour():
    from types import SimpleNamespace

    floor = SimpleNamespace(rows=140, cols=500, shelves=frozenset({(5, 5), (5, 6)}))
    robots = np.array([(0, 0), (139, 499), (70, 250)])
    packages = np.array([(1, 1), (0, 499), (5, 7)])
    frame = map_frames.fleet_map_frame(floor, robots, packages, parked=[False, False, True])
    assert frame.shape == (280, 1000, 3)
    assert frame.dtype == np.uint8
    assert (frame[0:2, 0:2] == map_frames.MAP_ROBOT_COLOURS[0]).all()
    assert (frame[278:280, 998:1000] == map_frames.MAP_ROBOT_COLOURS[1]).all()
    assert (frame[140:142, 500:502] == map_frames.MAP_DELIVERED).all()  # parked: green
    assert (frame[2:4, 2:4] == map_frames.MAP_PACKAGE).all()
    assert (frame[10:12, 10:12] == map_frames.MAP_SHELF).all()
    assert (frame[10:12, 14:16] == map_frames.MAP_FLOOR).all()  # robot 2's package: delivered


def test_a_parked_robot_keeps_its_colour_in_a_green_frame_and_packages_show_under_robots():
    from types import SimpleNamespace

    floor = SimpleNamespace(rows=3, cols=4, shelves=frozenset())
    robots = np.array([(0, 0), (2, 3)])
    packages = np.array([(2, 3), (1, 1)])  # robot_1 stands on robot_0's package
    frame = map_frames.fleet_map_frame(floor, robots, packages, parked=[False, True],
                                          cell_px=12)  # fmt: skip
    parked = frame[24:36, 36:48]
    assert (parked[0] == map_frames.MAP_DELIVERED).all()  # the frame's four sides
    assert (parked[-1] == map_frames.MAP_DELIVERED).all()
    assert (parked[:, 0] == map_frames.MAP_DELIVERED).all()
    assert (parked[:, -1] == map_frames.MAP_DELIVERED).all()
    assert (parked[3, 3] == map_frames.MAP_ROBOT_COLOURS[1]).all()  # its colour inside
    assert (parked[6, 6] == map_frames.MAP_PACKAGE).all()  # robot_0's package under it
    assert (frame[0:12, 0:12] == map_frames.MAP_ROBOT_COLOURS[0]).all()  # not framed
    with pytest.raises(ValueError, match="cell_px must be at least 1"):
        map_frames.fleet_map_frame(floor, robots, packages, cell_px=0)


def reference_map_frame(grid, robots, packages, parked, on_floor, px):
    """What fleet_map_frame promises, painted cell by cell with loops."""
    frame = np.empty((grid.rows * px, grid.cols * px, 3), dtype=np.uint8)

    def cell(row, col):
        return frame[row * px : (row + 1) * px, col * px : (col + 1) * px]

    for row in range(grid.rows):
        for col in range(grid.cols):
            shelf = (row, col) in grid.shelves
            cell(row, col)[:] = map_frames.MAP_SHELF if shelf else map_frames.MAP_FLOOR
    waiting = [i for i in range(len(robots)) if on_floor[i] and not parked[i]]
    for i in waiting:
        cell(*packages[i])[:] = map_frames.MAP_PACKAGE
    colours = map_frames.MAP_ROBOT_COLOURS
    for i in np.flatnonzero(on_floor):
        small_and_parked = parked[i] and px < 4
        cell(*robots[i])[:] = map_frames.MAP_DELIVERED if small_and_parked else colours[i % 8]
    border = max(1, px // 6)
    for i in np.flatnonzero(on_floor & parked) if px >= 4 else []:
        view = cell(*robots[i])
        for side in (view[:border], view[-border:], view[:, :border], view[:, -border:]):
            side[:] = map_frames.MAP_DELIVERED
    occupied = {tuple(robots[i]) for i in np.flatnonzero(on_floor)}
    for i in waiting if px >= 3 else []:
        if tuple(packages[i]) in occupied:
            cell(*packages[i])[px // 3 : px - px // 3, px // 3 : px - px // 3] = (
                map_frames.MAP_PACKAGE
            )
    return frame


def test_map_frames_paint_what_the_docstring_says_on_random_floors():
    rng = np.random.default_rng(5)
    for _ in range(60):
        rows, cols = (int(x) for x in rng.integers(2, 10, 2))
        layout = ["".join(rng.choice([".", ".", ".", "#"], cols)) for _ in range(rows)]
        layout[0] = "." * cols  # a floor needs free cells; shelves elsewhere at random
        floor = WarehouseGrid.from_layout(layout)
        n = int(rng.integers(0, 9))
        robots = rng.integers(0, [rows, cols], (n, 2))
        packages = rng.integers(0, [rows, cols], (n, 2))
        parked, on_floor = rng.random(n) < 0.4, rng.random(n) < 0.8
        px = int(rng.integers(1, 14))
        frame = map_frames.fleet_map_frame(floor, robots, packages, parked=parked,
                                              on_floor=on_floor, cell_px=px)  # fmt: skip
        expected = reference_map_frame(floor, robots, packages, parked, on_floor, px)
        assert (frame == expected).all()


def test_a_floor_is_painted_once_however_many_frames_are_drawn():
    floor = WarehouseGrid.from_layout(["....", ".##.", "...."])
    map_frames._floor_image.cache_clear()
    empty = map_frames.fleet_map_frame(floor, np.zeros((0, 2)), np.zeros((0, 2)), cell_px=5)
    for col in range(4):
        frame = map_frames.fleet_map_frame(floor, [(0, col)], [(2, 3 - col)], cell_px=5)
        assert (frame[0:5, col * 5 : col * 5 + 5] == map_frames.MAP_ROBOT_COLOURS[0]).all()
        frame[:] = 0  # a caller's frame is its own: the floor drawn next is untouched
    info = map_frames._floor_image.cache_info()
    assert (info.misses, info.hits) == (1, 4)
    again = map_frames.fleet_map_frame(floor, np.zeros((0, 2)), np.zeros((0, 2)), cell_px=5)
    assert (again == empty).all()
    assert (again[5:10, 5:15] == map_frames.MAP_SHELF).all()
    assert again.flags.writeable
