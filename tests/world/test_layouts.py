"""The warehouse layout presets and their registered environments."""

import ast
import os
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import warehouse_phys
from warehouse_phys import layouts as layouts_module
from warehouse_phys.files.atomic import temporary_files
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layout_text import MAX_SIDE
from warehouse_phys.world.layouts import (
    PRESETS,
    preset_ids,
    preset_name,
    resolve_layout,
    suggested_time_limit,
)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_presets_are_valid_warehouses_with_detours(name):
    preset = PRESETS[name]
    grid = resolve_layout(name)
    assert grid.layout == preset.rows
    assert len(grid.shelves) >= 6  # shelves, not an empty floor
    assert grid.target_cells
    # Somewhere the shelves make the shortest path longer than the Manhattan distance.
    assert any(
        grid.optimal_steps(cell, t) > abs(t[0] - cell[0]) + abs(t[1] - cell[1])
        for cell in grid.reachable
        for t in grid.target_cells
    )
    assert preset.description


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_preset_time_limits_let_random_walks_finish(name):
    grid = resolve_layout(name)
    limit = PRESETS[name].max_episode_steps
    assert limit == suggested_time_limit(grid)
    assert grid.random_walk_finish_rate(limit) >= 0.98
    assert grid.random_walk_finish_rate(limit - 100) < 0.98


def test_suggested_time_limit_of_the_default_floor_is_its_registered_limit():
    assert suggested_time_limit(WarehouseGrid(4, 5)) == warehouse_phys.DEFAULT_MAX_EPISODE_STEPS


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_each_preset_is_registered_in_both_worlds(name):
    grid_id, physics_id = preset_ids(name)
    assert (grid_id, physics_id) == (
        f"warehouse-robot-{name}-v0",
        f"warehouse-robot-phys-{name}-v0",
    )
    for env_id, cls in (
        (grid_id, warehouse_phys.WarehouseGridEnv),
        (physics_id, warehouse_phys.WarehousePhysicsEnv),
    ):
        env = gym.make(env_id)
        assert type(env.unwrapped) is cls
        assert env.spec.max_episode_steps == PRESETS[name].max_episode_steps
        assert env.unwrapped.grid.layout == PRESETS[name].rows
        rows, cols = len(PRESETS[name].rows), len(PRESETS[name].rows[0])
        assert env.observation_space == gym.spaces.MultiDiscrete([rows, cols, rows, cols])


def test_preset_name_recognises_only_the_presets_rows():
    assert preset_name(PRESETS["depot"].rows) == "depot"
    assert preset_name(list(PRESETS["maze"].rows)) == "maze"
    assert preset_name(["S.", ".P"]) is None


def test_unknown_preset_names_the_known_ones():
    with pytest.raises(ValueError, match="unknown layout preset 'office'; presets: aisles, depot"):
        resolve_layout("office")


def test_layouts_module_imports_no_simulation_or_gui_library():
    tree = ast.parse(Path(layouts_module.__file__).read_text())
    imported = {
        (node.module or "").split(".")[0]
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom)
    } | {
        alias.name.split(".")[0]
        for node in ast.walk(tree)
        if isinstance(node, ast.Import)
        for alias in node.names
    }
    assert not imported & {"gymnasium", "gym", "pymunk", "pygame"}


@pytest.mark.parametrize("size", [(6, 6), (8, 8), (10, 10)])
def test_small_floors_get_the_exact_random_walk_limit(size):
    grid = WarehouseGrid(*size)
    limit = suggested_time_limit(grid)
    assert grid.random_walk_finish_rate(limit) >= 0.98
    assert grid.random_walk_finish_rate(limit - 100) < 0.98


@pytest.mark.parametrize(
    ("grid", "limit"),
    [
        (WarehouseGrid(10, 11), 1400),  # 110 cells: 12 each, rounded up to 100
        (WarehouseGrid(100, 100), 120_000),
        (WarehouseGrid(512, 512), 3_145_800),
        (WarehouseGrid.from_layout(["S" + "." * 119, "#" * 119 + "."]), 1500),  # 121 reachable
    ],
)
def test_larger_floors_get_twelve_steps_per_reachable_cell(grid, limit):
    assert len(grid.reachable) > 100
    assert suggested_time_limit(grid) == limit


def test_the_exact_limit_does_not_rerun_the_walk_for_every_candidate():
    """The 14 x 14 floor took 93 s when each candidate limit restarted the walk."""
    grid = WarehouseGrid(10, 10)
    calls = []
    real = WarehouseGrid._finish_rates

    def counted(self):
        calls.append(1)
        return real(self)

    WarehouseGrid._finish_rates = counted
    try:
        assert suggested_time_limit(grid) == 1200
    finally:
        WarehouseGrid._finish_rates = real
    assert len(calls) == 1


@pytest.mark.parametrize("granularity", [0, -5, 2.5, True])
def test_a_granularity_that_is_not_a_positive_integer_is_refused(granularity):
    with pytest.raises(ValueError, match="granularity must be a positive integer"):
        suggested_time_limit(WarehouseGrid(4, 5), granularity)


# --------------------------------------------------------- MovingAI maps, the warehouse
MAPS = Path(__file__).resolve().parents[3] / "shared" / "maps"


def benchmark_map(name):
    path = MAPS / name
    if not path.is_file():
        pytest.skip(f"benchmark maps not found at {MAPS} (the shared folder beside the checkout)")
    return path


def write(tmp_path, text, name="floor.map"):
    path = tmp_path / name
    path.write_text(text)
    return path


MAP_TEXT = "type octile\nheight 3\nwidth 4\nmap\n@..E\n.T.G\nE..S\n"


def test_a_movingai_map_reads_as_a_floor(tmp_path):
    grid = layouts_module.read_movingai(write(tmp_path, MAP_TEXT))
    assert (grid.rows, grid.cols) == (3, 4)
    assert grid.shelves == {(0, 0), (1, 1)}
    assert grid.start == (0, 1)  # the first cell of the largest region
    assert not grid.starts_marked
    assert set(grid.target_cells) == set(grid.reachable) - {(0, 1)}
    endpoints = layouts_module.read_movingai(tmp_path / "floor.map", packages="endpoints")
    assert set(endpoints.target_cells) == {(0, 3), (2, 0)}
    assert resolve_layout(str(tmp_path / "floor.map")).shelves == grid.shelves
    assert resolve_layout(tmp_path / "floor.map").shelves == grid.shelves


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("type octile\nheight 3\n", "line 3: expected 'width <value>', got the end of the file"),
        ("type octile\nheight x\nwidth 4\nmap\n", "line 2: height must be an integer"),
        ("type octile\nheight 99999\nwidth 4\nmap\n", "line 2: height must be 1 to"),
        ("type octile\nheight 3\nwidth " + "9" * 5000 + "\nmap\n", "line 3: width must be 1 to"),
        (
            "type octile\nheight 3\nwidth 4\nmap\n@..E\n.\x0c.G\nE..S\n",
            r"line 6, column 2: unknown",
        ),
        ("type octile\nheight 1\nwidth 2\nmap\n@.\n.\n", "line 6: the header says 1 row,"),
        ("type octile\nheight 3\nwidth 4\nmapp\n", "line 4: expected 'map'"),
        ("type octile\nheight 3\nwidth 4\nmap\n@..E\n.T.G\n", "line 7: the header says 3 rows"),
        ("type octile\nheight 3\nwidth 4\nmap\n@..E\n.T.\nE..S\n", "line 6: a row of 3"),
        ("type octile\nheight 3\nwidth 4\nmap\n@..E\n.T.x\nE..S\n", "line 6, column 4: unknown"),
        ("type octile\nheight 1\nwidth 2\nmap\n@@\n", r"line 5 \(map row 0\): .*every cell is"),
        ("type octile\nheight 2\nwidth 2\nmap\n.@\n@.\n", r"lines 5-6 \(map rows 0-1\): .*no cell"),
        ("type octile\nheight 2\nwidth 2\nmap\n..\n..\n", None),
    ],
)
def test_malformed_maps_are_refused_in_one_line_naming_the_file(tmp_path, text, message):
    path = write(tmp_path, text)
    if message is None:
        with pytest.raises(ValueError, match="marks no 'E' cell"):
            layouts_module.read_movingai(path, packages="endpoints")
        return
    with pytest.raises(ValueError, match=message) as error:
        layouts_module.read_movingai(path)
    assert str(error.value).startswith(str(path))
    assert "\n" not in str(error.value)


def test_missing_binary_and_folder_maps_are_refused(tmp_path):
    for path, message in (
        (tmp_path / "none.map", "no such map file"),
        (tmp_path, "a folder, not a map file"),
        (write(tmp_path, "", "empty.map"), "line 1: expected 'type <value>'"),
    ):
        with pytest.raises(ValueError, match=message):
            layouts_module.read_movingai(path)
    pipe = tmp_path / "pipe.map"
    os.mkfifo(pipe)
    with pytest.raises(ValueError, match=r"pipe\.map: not a regular file"):
        layouts_module.read_movingai(pipe)
    with pytest.raises(ValueError, match="a path with a NUL character"):
        layouts_module.read_movingai(str(tmp_path / "a\0b.map"))
    with pytest.raises(ValueError, match=r"a\\nb\.map': no such map file") as error:
        layouts_module.read_movingai(tmp_path / "a\nb.map")
    assert "\n" not in str(error.value)
    junk = tmp_path / "junk.map"
    junk.write_bytes(b"type octile\n\x89PNG\x00\xff")
    with pytest.raises(ValueError, match="line 2, column 1: byte 0x89 is not ASCII text"):
        layouts_module.read_movingai(junk)
    with pytest.raises(ValueError, match="packages must be"):
        layouts_module.read_movingai(junk, packages="some")


def test_endpoints_out_of_reach_are_listed_briefly(tmp_path):
    text = "type octile\nheight 3\nwidth 400\nmap\n" + "\n".join(["E" * 400, "@" * 400, "E" * 400])
    with pytest.raises(
        ValueError, match=r"lines 5-7 .*\(2, 4\), \.\.\. \(400 in all\)\] cannot"
    ) as error:
        layouts_module.read_movingai(write(tmp_path, text), packages="endpoints")
    assert len(str(error.value)) < 300


def test_windows_line_ends_and_a_byte_order_mark_are_read(tmp_path):
    path = tmp_path / "floor.map"
    path.write_bytes(b"\xef\xbb\xbf" + MAP_TEXT.replace("\n", "\r\n").encode("ascii"))
    assert layouts_module.read_movingai(path).shelves == {(0, 0), (1, 1)}
    path.write_text(MAP_TEXT.replace(".T.G", ".T\u00e9G"), encoding="utf-8")
    with pytest.raises(ValueError, match=r"line 6, column 3: byte 0xc3 is not ASCII"):
        layouts_module.read_movingai(path)


def test_the_warehouse_preset_is_the_kiva_benchmark_floor():
    grid = resolve_layout("warehouse")
    assert (grid.rows, grid.cols) == (33, 46)
    assert not grid.starts_marked
    assert "warehouse" not in PRESETS  # a fleet floor, not a single robot's
    kiva = layouts_module.read_movingai(benchmark_map("kiva-33-46.map"))
    assert grid.shelves == kiva.shelves
    assert set(grid.target_cells) == set(kiva.target_cells)


def test_the_generator_builds_the_floor_it_is_asked_for():
    sizes = {"shelf_rows": 2, "blocks_per_row": 2, "block_length": 3, "aisle_width": 1,
             "gap_width": 2, "margin_rows": 1, "margin_cols": 1}  # fmt: skip
    rows = layouts_module.warehouse(**sizes)
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
    rows = layouts_module.warehouse(**sizes)
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
        layouts_module.warehouse(**kwargs)


@st.composite
def floors(draw):
    """Random small floors: shelves, floor, some package cells, starts anywhere."""
    rows, cols = draw(st.integers(1, 6)), draw(st.integers(2, 6))
    alphabet = draw(st.sampled_from(["#..", "#...P", "#..S", "#..SP"]))
    symbols = draw(st.lists(st.sampled_from(alphabet), min_size=rows * cols,
                            max_size=rows * cols))  # fmt: skip
    layout = ["".join(symbols[r * cols : (r + 1) * cols]) for r in range(rows)]
    try:
        return WarehouseGrid.from_layout(layout)
    except ValueError:  # unreachable starts or packages, or no cell for a package
        assume(False)


@settings(max_examples=60, deadline=None)
@given(grid=st.one_of(floors(), st.builds(WarehouseGrid, st.integers(2, 5), st.integers(2, 5))))
def test_written_maps_read_back_as_the_same_floor(tmp_path_factory, grid):
    path = layouts_module.write_movingai(grid, tmp_path_factory.mktemp("maps") / "out.map")
    text = path.read_text()
    assert text.startswith(f"type octile\nheight {grid.rows}\nwidth {grid.cols}\nmap\n")
    again = layouts_module.read_movingai(path, packages="endpoints" if "E" in text else "all")
    assert (again.rows, again.cols) == (grid.rows, grid.cols)
    assert again.shelves == grid.shelves
    assert set(again.target_cells) == set(grid.target_cells)
    assert not again.starts_marked


def test_maps_of_connected_floors_without_a_start_are_written_without_endpoints(tmp_path):
    for rows, endpoints in ((["..", ".#"], False), (["S.", ".#"], False),
                            ([".S", ".#"], True), ([".P", ".#"], True),
                            ([".#.", "##."], False)):  # fmt: skip
        grid = WarehouseGrid.from_layout(rows)
        text = layouts_module.write_movingai(grid, tmp_path / "floor.map").read_text()
        assert ("E" in text) == endpoints, rows


def test_large_benchmark_maps_read_quickly_and_whole():
    import time

    started = time.process_time()
    grid = layouts_module.read_movingai(benchmark_map("warehouse-large-140-500.map"))
    assert time.process_time() - started < 5  # generous: about 0.2 s here
    assert (grid.rows, grid.cols) == (140, 500)
    assert len(grid.reachable) == 38_586
    endpoints = layouts_module.read_movingai(MAPS / "warehouse-large-140-500.map",
                                             packages="endpoints")  # fmt: skip
    assert len(endpoints.target_cells) == 352


def test_every_environment_takes_a_map_file(tmp_path):
    import numpy as np

    from warehouse_phys.envs import fleet

    path = write(tmp_path, MAP_TEXT)
    for env_id in ("warehouse-robot-v0", "warehouse-robot-phys-v0"):
        env = gym.make(env_id, layout=str(path))
        assert env.unwrapped.grid.shelves == {(0, 0), (1, 1)}
        env.close()
    vector = gym.make_vec("warehouse-robot-v0", num_envs=3, layout=str(path))
    observations, _ = vector.reset(seed=0)
    assert observations.shape == (3, 4)
    vector.close()
    robots = fleet.parallel_env(num_robots=2, layout=str(path), starts="random")
    robots.reset(seed=0)
    assert not np.isin([0, 5], robots.robot_cells[:, 0] * 4 + robots.robot_cells[:, 1]).any()


def test_maps_are_written_atomically(tmp_path):
    path = tmp_path / "floor.map"
    layouts_module.write_movingai(WarehouseGrid.from_layout(["..", ".#"]), path)
    layouts_module.write_movingai(WarehouseGrid.from_layout(["...", "#.."]), path)
    assert path.read_text() == "type octile\nheight 2\nwidth 3\nmap\n...\n@..\n"
    (tmp_path / "taken.map").mkdir()
    with pytest.raises(IsADirectoryError):
        layouts_module.write_movingai(WarehouseGrid(2, 2), tmp_path / "taken.map")
    assert temporary_files(tmp_path, "floor.map") == []
    assert temporary_files(tmp_path, "taken.map") == []


# -------------------------------------------------- maps up to 2,048 x 2,048 (issue 32)
def random_floor(rows, cols, seed=0, share=0.1):
    """A ``rows`` x ``cols`` floor with about ``share`` of its cells shelves, as layout rows."""
    shelves = np.random.default_rng(seed).random((rows, cols)) < share
    shelves[0, 0] = False
    symbols = np.where(shelves, ord("#"), ord(".")).astype(np.uint8)
    return [row.tobytes().decode("ascii") for row in symbols]


def test_the_largest_floors_are_written_and_read_back(tmp_path):
    import time

    grid = WarehouseGrid.from_layout(random_floor(MAX_SIDE, MAX_SIDE))
    began = time.process_time()
    path = layouts_module.write_movingai(grid, tmp_path / "big.map")
    again = layouts_module.read_movingai(path)
    assert time.process_time() - began < 10  # generous: about 1 s here
    assert MAX_SIDE == 2048
    assert path.stat().st_size == len("type octile\nheight 2048\nwidth 2048\nmap\n") + 2048 * 2049
    assert (again.rows, again.cols) == (2048, 2048)
    assert np.array_equal(again.shelf_mask, grid.shelf_mask)
    assert np.array_equal(again.target_indices, grid.target_indices)


@pytest.mark.parametrize(("height", "width"), [(3, 1491), (656, 3), (1912, 2), (2, 2048)])
def test_maps_wider_or_taller_than_the_old_limit_are_read(tmp_path, height, width):
    text = f"type octile\nheight {height}\nwidth {width}\nmap\n" + ("." * width + "\n") * height
    grid = layouts_module.read_movingai(write(tmp_path, text))
    assert (grid.rows, grid.cols) == (height, width)
    assert len(grid.reachable) == height * width


@pytest.mark.parametrize(
    ("size", "message"),
    [
        ("height 2049\nwidth 4", "line 2: height must be 1 to 2048 (the largest floor), got 2049"),
        ("height 3\nwidth 99999", "line 3: width must be 1 to 2048 (the largest floor), got 99999"),
        ("height -0000000000003\nwidth 4", "line 2: height must be 1 to 2048"),
        ("height 0000\nwidth 4", "line 2: height must be 1 to 2048"),
    ],
)
def test_map_sizes_beyond_the_largest_floor_are_refused_by_the_header(tmp_path, size, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        layouts_module.read_movingai(write(tmp_path, f"type octile\n{size}\nmap\n....\n"))


def test_sizes_with_leading_zeros_are_read(tmp_path):
    text = "type octile\nheight 0000000000003\nwidth +00000000000000000004\nmap\n"
    text += MAP_TEXT.split("map\n", 1)[1]
    grid = layouts_module.read_movingai(write(tmp_path, text))
    assert (grid.rows, grid.cols) == (3, 4)
    assert grid.shelves == {(0, 0), (1, 1)}


@pytest.mark.parametrize(
    ("name", "height", "width", "extra"),
    [("orz900d.map", 3, 1491, 5000), ("scene.map", 1912, 2, 2 * 1_000_000)],
)
def test_a_file_longer_than_its_headers_map_is_refused_with_the_headers_size(
    tmp_path, name, height, width, extra
):
    text = f"type octile\nheight {height}\nwidth {width}\nmap\n" + ("." * width + "\n") * height
    path = write(tmp_path, text + "." * extra, name)
    with pytest.raises(ValueError, match=f"longer than a map of {height} x {width} cells") as error:
        layouts_module.read_movingai(path)
    assert str(error.value).startswith(f"{path}: {len(text) + extra:,} bytes, ")
    assert "\n" not in str(error.value)
    # Blank lines and spaces at the end, within the slack, are still read.
    path.write_text(text + "\n" * 100)
    assert layouts_module.read_movingai(path).rows == height


def test_a_header_longer_than_any_header_is_refused(tmp_path):
    path = write(tmp_path, "type " + "x" * (1 << 17) + "\nheight 2\nwidth 2\nmap\n..\n..\n")
    with pytest.raises(ValueError, match=r"the header's 4 lines are longer than 65,536 bytes"):
        layouts_module.read_movingai(path)


def test_a_path_of_bytes_is_refused_naming_the_argument(tmp_path):
    class BytesPath:
        def __fspath__(self):
            return b"/x.map"

    for path in (b"/x.map", BytesPath(), 3, None):
        with pytest.raises(TypeError, match=r"^path must be a str or an os\.PathLike of a str"):
            layouts_module.read_movingai(path)
