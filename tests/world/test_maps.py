"""Floors made by rule (the Kiva warehouse, random shelves, mazes) and the benchmark maps
the package ships, made by them."""

import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from warehouse_phys.world import layouts, maps
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import FLEET_PRESETS, PRESETS, resolve_layout
from warehouse_phys.world.maps import (
    MAP_FOLDER,
    MAPS,
    map_path,
    maze,
    random_floor,
    warehouse,
    write_map,
    write_maps,
)
from warehouse_phys.world.movingai import read_movingai

#: The benchmark maps beside the repository (MovingAI), absent on a fresh clone.
SHARED_MAPS = Path(__file__).resolve().parents[3] / "shared" / "maps"


def benchmark_map(name):
    path = SHARED_MAPS / name
    if not path.is_file():
        pytest.skip(f"benchmark maps not found at {SHARED_MAPS} (the folder beside the checkout)")
    return path


# --------------------------------------------------------------- the shipped maps
@pytest.mark.parametrize("name", sorted(MAPS))
def test_each_shipped_map_is_what_its_generator_writes_today(name, tmp_path):
    # A generator that changes fails here until write_maps() writes the files again.
    shipped = map_path(name)
    assert shipped.parent == MAP_FOLDER
    assert shipped.read_bytes() == write_map(name, tmp_path / f"{name}.map").read_bytes()


@pytest.mark.parametrize("name", sorted(MAPS))
def test_each_shipped_map_reads_by_its_name_without_a_word(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no extra lines, nothing to say
        grid = resolve_layout(name)
    rows = MAPS[name].rows()
    assert (grid.rows, grid.cols) == (len(rows), len(rows[0]))
    assert grid.shelves == read_movingai(map_path(name)).shelves
    assert grid.shelf_mask.sum() == sum(row.count("#") for row in rows)
    assert map_path(name).read_text().startswith(f"type octile\nheight {grid.rows}\n")


def test_the_folder_holds_the_shipped_maps_and_nothing_else():
    assert sorted(path.name for path in MAP_FOLDER.iterdir()) == sorted(f"{n}.map" for n in MAPS)
    assert sum(path.stat().st_size for path in MAP_FOLDER.iterdir()) < 100_000  # small: 77 KB


def test_the_shipped_maps_are_what_their_descriptions_say():
    kiva = resolve_layout("kiva-33-46")
    assert (
        kiva.shelf_mask.tolist()
        == WarehouseGrid.from_layout(FLEET_PRESETS["warehouse"]).shelf_mask.tolist()
    )
    large = resolve_layout("kiva-140-500")
    assert (large.rows, large.cols, len(large.reachable)) == (140, 500, 49_300)
    assert len(large.target_indices) >= 2 * 10_000  # 10,000 robots, lifelong
    random = resolve_layout("random-64-64-10-seed0")
    assert (random.rows, random.cols) == (64, 64)
    assert abs(random.shelf_mask.mean() - 0.1) < 0.02
    mazy = resolve_layout("maze-32-32-2-seed0")
    assert (mazy.rows, mazy.cols) == (32, 32)
    assert len(mazy.reachable) == int((~mazy.shelf_mask).sum())  # one region


def test_the_kiva_map_is_the_benchmarks_file_byte_for_byte():
    assert map_path("kiva-33-46").read_bytes() == benchmark_map("kiva-33-46.map").read_bytes()


def test_an_unknown_map_name_lists_the_shipped_ones(tmp_path):
    with pytest.raises(
        ValueError, match="unknown benchmark map 'kiva'; the package ships kiva-33-46"
    ):
        map_path("kiva")
    with pytest.raises(ValueError, match="shipped maps: kiva-33-46, kiva-140-500"):
        resolve_layout("kiva")
    written = write_maps(tmp_path)
    assert [path.name for path in written] == [f"{name}.map" for name in MAPS]
    assert all(path.read_bytes() == map_path(path.stem).read_bytes() for path in written)


def test_every_environment_and_fleet_takes_a_shipped_maps_name():
    import gymnasium as gym

    from warehouse_phys.envs import fleet

    env = gym.make("warehouse-robot-v0", layout="maze-32-32-2-seed0")
    env.reset(seed=0)
    assert env.unwrapped.grid.rows == 32
    env.close()
    robots = fleet.parallel_env(num_robots=64, layout="kiva-33-46", max_cycles=2)
    robots.reset(seed=0)
    assert robots.grid.shelves == resolve_layout("warehouse").shelves


def test_the_generators_moved_here_still_import_from_the_layouts():
    assert layouts.warehouse is warehouse
    assert layouts.read_movingai is read_movingai
    assert maps.warehouse() == FLEET_PRESETS["warehouse"]
    assert "warehouse" not in PRESETS


# -------------------------------------------------------- the Kiva warehouse generator
def test_the_warehouse_preset_is_the_kiva_benchmark_floor():
    grid = resolve_layout("warehouse")
    assert (grid.rows, grid.cols) == (33, 46)
    assert not grid.starts_marked
    assert "warehouse" not in PRESETS  # a fleet floor, not a single robot's
    kiva = read_movingai(benchmark_map("kiva-33-46.map"))
    assert grid.shelves == kiva.shelves
    assert set(grid.target_cells) == set(kiva.target_cells)


def test_the_generator_builds_the_floor_it_is_asked_for():
    sizes = {"shelf_rows": 2, "blocks_per_row": 2, "block_length": 3, "aisle_width": 1,
             "gap_width": 2, "margin_rows": 1, "margin_cols": 1}  # fmt: skip
    rows = warehouse(**sizes)
    assert rows == (
        "..........",
        ".###..###.",
        "..........",
        ".###..###.",
        "..........",
    )


@pytest.mark.parametrize(
    ("sizes", "shape"),
    [
        ({}, (33, 46)),
        ({"shelf_rows": 3, "blocks_per_row": 4, "block_length": 5}, (13, 37)),
        ({"shelf_rows": 1, "aisle_width": 9, "margin_rows": 1, "margin_cols": 0}, (3, 32)),
    ],
)
def test_the_generator_gives_the_sizes_and_counts_of_its_parameters(sizes, shape):
    kw = {"shelf_rows": 8, "blocks_per_row": 3, "block_length": 10, **sizes}
    rows = warehouse(**sizes)
    assert (len(rows), len(rows[0])) == shape
    assert sum(row.count("#") for row in rows) == (
        kw["shelf_rows"] * kw["blocks_per_row"] * kw["block_length"]
    )
    shelf_rows = [row for row in rows if "#" in row]
    assert len(shelf_rows) == kw["shelf_rows"]
    assert all(row.count("#" * kw["block_length"]) == kw["blocks_per_row"] for row in shelf_rows)
    grid = WarehouseGrid.from_layout(rows)
    assert not grid.starts_marked
    assert len(grid.reachable) == grid.rows * grid.cols - len(grid.shelves)  # connected


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"shelf_rows": 0}, ValueError, "shelf_rows must be at least 1"),
        ({"block_length": 2.5}, TypeError, "block_length must be an integer"),
        ({"margin_cols": -1}, ValueError, "margin_cols must be at least 0"),
        ({"shelf_rows": 5000}, ValueError, "the largest floor"),
        ({"shelf_rows": 1, "margin_rows": 0}, ValueError, "margin_rows must be at least 1 when"),
        ({"blocks_per_row": 1, "margin_cols": 0}, ValueError, "margin_cols must be at least 1"),
    ],
)
def test_the_generator_refuses_bad_sizes_by_name(kwargs, error, message):
    with pytest.raises(error, match=message):
        warehouse(**kwargs)


# --------------------------------------------------------------- random floors
@settings(max_examples=40, deadline=None)
@given(
    rows=st.integers(2, 40),
    cols=st.integers(2, 40),
    density=st.floats(0, 0.99),
    seed=st.integers(0, 2**32),
)
def test_a_random_floor_is_its_seeds_and_its_size(rows, cols, density, seed):
    floor = random_floor(rows, cols, density, seed)
    assert floor == random_floor(rows, cols, density, seed)  # the same seed, the same floor
    assert (len(floor), {len(row) for row in floor}) == (rows, {cols})
    assert set("".join(floor)) <= {".", "#"}
    assert floor[0][0] == "."
    expected = np.random.default_rng(seed).random((rows, cols)) < density
    expected[0, 0] = False
    assert [[s == "#" for s in row] for row in floor] == expected.tolist()


def test_random_floors_differ_by_seed_and_refuse_bad_arguments_by_name():
    assert random_floor(16, 16, 0.3, 0) != random_floor(16, 16, 0.3, 1)
    assert "#" not in "".join(random_floor(8, 8, 0.0))
    for kwargs, error, message in (
        ({"rows": 1, "cols": 4}, ValueError, "rows must be at least 2"),
        ({"rows": 4, "cols": 4.0}, TypeError, "cols must be an integer"),
        ({"rows": 4, "cols": 4, "density": 1.0}, ValueError, r"density must be in \[0, 1\)"),
        ({"rows": 4, "cols": 4, "density": float("nan")}, ValueError, "density must be in"),
        ({"rows": 4, "cols": 4, "density": "0.1"}, TypeError, "density must be a number"),
        ({"rows": 4, "cols": 4, "seed": -1}, ValueError, "seed must be 0 or more"),
        ({"rows": 4, "cols": 4, "seed": 1.5}, TypeError, "seed must be an integer"),
    ):
        with pytest.raises(error, match=message):
            random_floor(**kwargs)


# ------------------------------------------------------------------------ mazes
@settings(max_examples=40, deadline=None)
@given(
    rows=st.integers(3, 40),
    cols=st.integers(3, 40),
    corridor=st.integers(1, 4),
    seed=st.integers(0, 2**32),
)
def test_a_maze_is_one_region_of_corridors_framed_by_wall(rows, cols, corridor, seed):
    pitch = corridor + 1
    rooms = ((rows - 1) // pitch) * ((cols - 1) // pitch)
    if rooms < 2:
        with pytest.raises(ValueError, match="needs two rooms and their walls"):
            maze(rows, cols, corridor, seed)
        return
    floor = maze(rows, cols, corridor, seed)
    assert floor == maze(rows, cols, corridor, seed)
    shelves = np.array([[s == "#" for s in row] for row in floor])
    assert shelves.shape == (rows, cols)
    for wall in (shelves[0], shelves[:, 0], shelves[-1], shelves[:, -1]):
        assert wall.all()
    _, regions = ndimage.label(~shelves)  # four-connected
    assert regions == 1
    # Every room of the lattice is open, joined to the others as a tree: rooms - 1 doors.
    assert (~shelves).sum() == rooms * corridor**2 + (rooms - 1) * corridor  # a tree of rooms
    WarehouseGrid.from_layout(floor)  # a floor a fleet can use


def test_mazes_differ_by_seed_and_refuse_bad_arguments_by_name():
    assert maze(20, 20, 1, 0) != maze(20, 20, 1, 1)
    for kwargs, error, message in (
        ({"rows": 3, "cols": 9, "corridor": 2}, ValueError, "needs two rooms and their walls"),
        ({"rows": 3, "cols": 3, "corridor": 1}, ValueError, "3 x 5 cells or 5 x 3, got 3 x 3"),
        ({"rows": 9, "cols": 9, "corridor": 0}, ValueError, "corridor must be at least 1"),
        ({"rows": 9, "cols": 9, "corridor": True}, TypeError, "corridor must be an integer"),
        ({"rows": 9, "cols": 5000}, ValueError, "cols must be at most 2048"),
        ({"rows": 9, "cols": 9, "seed": -2}, ValueError, "seed must be 0 or more"),
    ):
        with pytest.raises(error, match=message):
            maze(**kwargs)
