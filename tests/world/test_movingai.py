"""MovingAI map files: read as the competition reads them, written back, refused in one line."""

import os
import re
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from warehouse_phys.files.atomic import temporary_files
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layout_text import MAX_SIDE
from warehouse_phys.world.layouts import resolve_layout
from warehouse_phys.world.maps import random_floor
from warehouse_phys.world.movingai import MAP_FILE_FACTOR, read_movingai, write_movingai

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
    grid = read_movingai(write(tmp_path, MAP_TEXT))
    assert (grid.rows, grid.cols) == (3, 4)
    assert grid.shelves == {(0, 0), (1, 1)}
    assert grid.start == (0, 1)  # the first cell of the largest region
    assert not grid.starts_marked
    assert set(grid.target_cells) == set(grid.reachable) - {(0, 1)}
    endpoints = read_movingai(tmp_path / "floor.map", packages="endpoints")
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
        ("type octile\nheight 2\nwidth 2\nmap\n@.\n", "line 6: the header says 2 rows,"),
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
            read_movingai(path, packages="endpoints")
        return
    with pytest.raises(ValueError, match=message) as error:
        read_movingai(path)
    assert str(error.value).startswith(str(path))
    assert "\n" not in str(error.value)


def test_missing_binary_and_folder_maps_are_refused(tmp_path):
    for path, message in (
        (tmp_path / "none.map", "no such map file"),
        (tmp_path, "a folder, not a map file"),
        (write(tmp_path, "", "empty.map"), "line 1: expected 'type <value>'"),
    ):
        with pytest.raises(ValueError, match=message):
            read_movingai(path)
    pipe = tmp_path / "pipe.map"
    os.mkfifo(pipe)
    with pytest.raises(ValueError, match=r"pipe\.map: not a regular file"):
        read_movingai(pipe)
    with pytest.raises(ValueError, match="a path with a NUL character"):
        read_movingai(str(tmp_path / "a\0b.map"))
    with pytest.raises(ValueError, match=r"a\\nb\.map': no such map file") as error:
        read_movingai(tmp_path / "a\nb.map")
    assert "\n" not in str(error.value)
    junk = tmp_path / "junk.map"
    junk.write_bytes(b"type octile\n\x89PNG\x00\xff")
    with pytest.raises(ValueError, match="line 2, column 1: byte 0x89 is not ASCII text"):
        read_movingai(junk)
    with pytest.raises(ValueError, match="packages must be"):
        read_movingai(junk, packages="some")


def test_endpoints_out_of_reach_are_listed_briefly(tmp_path):
    text = "type octile\nheight 3\nwidth 400\nmap\n" + "\n".join(["E" * 400, "@" * 400, "E" * 400])
    with pytest.raises(
        ValueError, match=r"lines 5-7 .*\(2, 4\), \.\.\. \(400 in all\)\] cannot"
    ) as error:
        read_movingai(write(tmp_path, text), packages="endpoints")
    assert len(str(error.value)) < 300


def test_windows_line_ends_and_a_byte_order_mark_are_read(tmp_path):
    path = tmp_path / "floor.map"
    path.write_bytes(b"\xef\xbb\xbf" + MAP_TEXT.replace("\n", "\r\n").encode("ascii"))
    assert read_movingai(path).shelves == {(0, 0), (1, 1)}
    path.write_text(MAP_TEXT.replace(".T.G", ".T\u00e9G"), encoding="utf-8")
    with pytest.raises(ValueError, match=r"line 6, column 3: byte 0xc3 is not ASCII"):
        read_movingai(path)


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
    path = write_movingai(grid, tmp_path_factory.mktemp("maps") / "out.map")
    text = path.read_text()
    assert text.startswith(f"type octile\nheight {grid.rows}\nwidth {grid.cols}\nmap\n")
    again = read_movingai(path, packages="endpoints" if "E" in text else "all")
    assert (again.rows, again.cols) == (grid.rows, grid.cols)
    assert again.shelves == grid.shelves
    assert set(again.target_cells) == set(grid.target_cells)
    assert not again.starts_marked


def test_maps_of_connected_floors_without_a_start_are_written_without_endpoints(tmp_path):
    for rows, endpoints in ((["..", ".#"], False), (["S.", ".#"], False),
                            ([".S", ".#"], True), ([".P", ".#"], True),
                            ([".#.", "##."], False)):  # fmt: skip
        grid = WarehouseGrid.from_layout(rows)
        text = write_movingai(grid, tmp_path / "floor.map").read_text()
        assert ("E" in text) == endpoints, rows


def test_large_benchmark_maps_read_quickly_and_whole():
    import time

    started = time.process_time()
    grid = read_movingai(benchmark_map("warehouse-large-140-500.map"))
    assert time.process_time() - started < 5  # generous: about 0.2 s here
    assert (grid.rows, grid.cols) == (140, 500)
    assert len(grid.reachable) == 38_586
    endpoints = read_movingai(MAPS / "warehouse-large-140-500.map",
                                             packages="endpoints")  # fmt: skip
    assert len(endpoints.target_cells) == 352


def test_every_environment_takes_a_map_file(tmp_path):
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
    write_movingai(WarehouseGrid.from_layout(["..", ".#"]), path)
    write_movingai(WarehouseGrid.from_layout(["...", "#.."]), path)
    assert path.read_text() == "type octile\nheight 2\nwidth 3\nmap\n...\n@..\n"
    (tmp_path / "taken.map").mkdir()
    with pytest.raises(IsADirectoryError):
        write_movingai(WarehouseGrid(2, 2), tmp_path / "taken.map")
    assert temporary_files(tmp_path, "floor.map") == []
    assert temporary_files(tmp_path, "taken.map") == []


# -------------------------------------------------- maps up to 2,048 x 2,048 (issue 32)
def test_the_largest_floors_are_written_and_read_back(tmp_path):
    import time

    grid = WarehouseGrid.from_layout(random_floor(MAX_SIDE, MAX_SIDE))
    began = time.process_time()
    path = write_movingai(grid, tmp_path / "big.map")
    again = read_movingai(path)
    assert time.process_time() - began < 10  # generous: about 1 s here
    assert MAX_SIDE == 2048
    assert path.stat().st_size == len("type octile\nheight 2048\nwidth 2048\nmap\n") + 2048 * 2049
    assert (again.rows, again.cols) == (2048, 2048)
    assert np.array_equal(again.shelf_mask, grid.shelf_mask)
    assert np.array_equal(again.target_indices, grid.target_indices)


@pytest.mark.parametrize(("height", "width"), [(3, 1491), (656, 3), (1912, 2), (2, 2048)])
def test_maps_wider_or_taller_than_the_old_limit_are_read(tmp_path, height, width):
    text = f"type octile\nheight {height}\nwidth {width}\nmap\n" + ("." * width + "\n") * height
    grid = read_movingai(write(tmp_path, text))
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
        read_movingai(write(tmp_path, f"type octile\n{size}\nmap\n....\n"))


def test_sizes_with_leading_zeros_are_read(tmp_path):
    text = "type octile\nheight 0000000000003\nwidth +00000000000000000004\nmap\n"
    text += MAP_TEXT.split("map\n", 1)[1]
    grid = read_movingai(write(tmp_path, text))
    assert (grid.rows, grid.cols) == (3, 4)
    assert grid.shelves == {(0, 0), (1, 1)}


@pytest.mark.parametrize(
    ("name", "height", "width", "extra"),
    [("orz900d.map", 3, 1491, 20_000), ("scene.map", 1912, 2, 2 * 1_000_000)],
)
def test_a_file_longer_than_twice_its_headers_map_is_refused_with_the_headers_size(
    tmp_path, name, height, width, extra
):
    text = f"type octile\nheight {height}\nwidth {width}\nmap\n" + ("." * width + "\n") * height
    path = write(tmp_path, text + "." * extra, name)
    with pytest.raises(
        ValueError, match=f"longer than 2 maps of {height} x {width} cells"
    ) as error:
        read_movingai(path)
    assert str(error.value).startswith(f"{path}: {len(text) + extra:,} bytes, ")
    assert "\n" not in str(error.value)
    # Blank lines and spaces at the end are still read, without a word.
    path.write_text(text + "\n" * 100 + "  \r\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_movingai(path).rows == height


# ------------------------------------ rows after the header's height (issue 41)
TWICE = "type octile\nheight 3\nwidth 4\nmap\n@..E\n.T.G\nE..S\n"


@pytest.mark.parametrize(
    ("after", "ignored"),
    [
        (TWICE, "7 lines"),  # the whole file again, as the 2023 examples' Paris maps
        ("@..E\n.T.G\nE..S", "3 lines"),  # the rows again, the last without its line end
        ("\nnotes: \xe9t\xe9\n\n", "3 lines"),  # not even ASCII: never decoded
        ("@.\n", "1 line"),  # a row of the wrong width, after the map: ignored too
    ],
)
def test_rows_after_the_headers_height_are_ignored_with_a_warning(tmp_path, after, ignored):
    # The League of Robot Runners' reader reads `height` rows and ignores the rest.
    path = tmp_path / "Paris_1_256.map"
    path.write_bytes((TWICE + after).encode("latin-1"))
    with pytest.warns(UserWarning, match="after the header's 3 rows ignored") as caught:
        grid = read_movingai(path)
    assert [str(w.message) for w in caught] == [
        f"{path}: {ignored} after the header's 3 rows ignored (as the League of Robot Runners' "
        "reader ignores them)"
    ]
    assert caught[0].filename == __file__  # it points at the caller, not at the reader
    once = read_movingai(write(tmp_path, TWICE, "once.map"))
    assert grid.shelves == once.shelves
    assert np.array_equal(grid.target_indices, once.target_indices)
    path.write_bytes((TWICE + after).replace("\n", "\r\n").encode("latin-1"))
    with pytest.warns(UserWarning, match=ignored):
        assert read_movingai(path).shelves == once.shelves
    with pytest.warns(UserWarning, match=ignored):
        assert resolve_layout(path).shelves == once.shelves


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ("@..E\n.T.\nE..S\n" + TWICE, "line 6: a row of 3 symbols; the header says 4"),
        ("@..E\n.T.GG\nE..S\n" + TWICE, "line 6: a row of 5 symbols; the header says 4"),
        ("@..E\n.T.G\n", "line 7: the header says 3 rows, the file has 2"),
    ],
)
def test_rows_of_the_wrong_length_or_number_are_refused_whatever_follows(tmp_path, rows, message):
    path = write(tmp_path, "type octile\nheight 3\nwidth 4\nmap\n" + rows)
    with pytest.raises(ValueError, match=re.escape(message)):
        read_movingai(path)


def test_a_map_with_as_much_again_after_it_is_read_and_one_byte_more_refused(tmp_path):
    text = "type octile\nheight 2\nwidth 2\nmap\n..\n..\n"
    limit = (len("type octile\nheight 2\nwidth 2\nmap\n") + 2 * 4 + 4096) * MAP_FILE_FACTOR
    path = write(tmp_path, text + "x" * (limit - len(text)))
    with pytest.warns(UserWarning, match="1 line after"):
        assert read_movingai(path).rows == 2
    path.write_text(text + "x" * (limit - len(text) + 1))
    with pytest.raises(ValueError, match=f"at most {limit:,} bytes"):
        read_movingai(path)


@settings(max_examples=40, deadline=None)
@given(
    grid=st.builds(WarehouseGrid, st.integers(2, 6), st.integers(2, 6)),
    after=st.binary(max_size=200),
)
def test_whatever_follows_the_rows_the_map_reads_the_same(tmp_path_factory, grid, after):
    path = write_movingai(grid, tmp_path_factory.mktemp("maps") / "floor.map")
    path.write_bytes(path.read_bytes() + after)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        again = read_movingai(path)
    assert again.shelves == grid.shelves
    assert len(caught) == (1 if after.strip() else 0)


def test_a_header_longer_than_any_header_is_refused(tmp_path):
    path = write(tmp_path, "type " + "x" * (1 << 17) + "\nheight 2\nwidth 2\nmap\n..\n..\n")
    with pytest.raises(ValueError, match=r"the header's 4 lines are longer than 65,536 bytes"):
        read_movingai(path)


def test_a_path_of_bytes_is_refused_naming_the_argument(tmp_path):
    class BytesPath:
        def __fspath__(self):
            return b"/x.map"

    for path in (b"/x.map", BytesPath(), 3, None):
        with pytest.raises(TypeError, match=r"^path must be a str or an os\.PathLike of a str"):
            read_movingai(path)
