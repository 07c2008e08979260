"""Loading a table file holds at most the table its grid needs plus 1 MiB, for every file.

Each figure is the peak resident memory of a fresh process while it loads one file,
above what it held just before (Linux's peak counter, reset first), so that nothing
the test process did before counts.
"""

import io
import json
import struct
import subprocess
import sys
import textwrap
import zipfile

import numpy as np
import pytest

from tests.memory import CAN_MEASURE
from warehouse_phys.rl.qlearning import (
    QLearningConfig,
    QTableError,
    load_q_table,
    make_table_metadata,
    save_q_table,
    table_bytes,
)
from warehouse_phys.world.grid import WarehouseGrid

pytestmark = pytest.mark.skipif(
    not CAN_MEASURE, reason="resident memory is read from Linux's /proc"
)

#: A floor whose table (25.9 MB) dwarfs the measuring's noise, and loads in a blink.
SIDE = 30
TABLE = table_bytes(SIDE, SIDE)
SLACK = 2**20  # the Limits page's bound (docs/limits.md): the table its grid needs, plus 1 MiB

PEAK_OF_LOADING = textwrap.dedent(
    """
    import gc, json, sys
    from warehouse_phys.rl.qlearning import QTableError, load_q_table

    def status(field):
        with open("/proc/self/status") as lines:
            for line in lines:
                if line.startswith(field + ":"):
                    return int(line.split()[1]) * 1024

    load_q_table(sys.argv[2])  # every code path runs once before the measuring
    gc.collect()
    with open("/proc/self/clear_refs", "w") as clear:
        clear.write("5")  # the peak counter starts again from what the process holds now
    before = status("VmRSS")
    try:
        q, _ = load_q_table(sys.argv[1])
        outcome = f"loaded {q.shape} {q.dtype}"
    except QTableError as error:
        outcome = str(error)
    print(json.dumps({"peak": status("VmHWM") - before, "outcome": outcome}))
    """
)


def peak_of_loading(path, warm_up):
    """The peak memory of loading ``path`` in a fresh process [bytes], and what it said."""
    result = subprocess.run(
        [sys.executable, "-c", PEAK_OF_LOADING, str(path), str(warm_up)],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    figures = json.loads(result.stdout)
    return figures["peak"], figures["outcome"]


def metadata(side):
    grid = WarehouseGrid(side, side)
    return make_table_metadata("warehouse-robot-v0", grid, QLearningConfig())


@pytest.fixture(scope="module")
def warm_up(tmp_path_factory):
    """A small valid table, loaded once before each measuring."""
    path = tmp_path_factory.mktemp("warm") / "small.npz"
    return save_q_table(path, np.zeros((3, 3, 3, 3, 4)), metadata(3))


def test_a_valid_float64_table_loads_within_the_bound(tmp_path, warm_up):
    path = save_q_table(tmp_path / "q.npz", np.zeros((SIDE, SIDE, SIDE, SIDE, 4)), metadata(SIDE))
    peak, outcome = peak_of_loading(path, warm_up)
    assert outcome == f"loaded {(SIDE, SIDE, SIDE, SIDE, 4)} float64"
    assert TABLE <= peak <= TABLE + SLACK, peak / TABLE  # was 3 tables: the file's, two copies


def test_a_long_double_table_loads_within_the_bound_of_its_float64_table(tmp_path, warm_up):
    path = tmp_path / "q.npz"
    q = np.zeros((SIDE, SIDE, SIDE, SIDE, 4), dtype=np.longdouble)
    text = json.dumps(metadata(SIDE), sort_keys=True)
    np.savez_compressed(path, q=q, metadata=np.array(text))
    assert path.stat().st_size < 2**20  # a small file declaring twice the table
    peak, outcome = peak_of_loading(path, warm_up)
    assert outcome == f"loaded {(SIDE, SIDE, SIDE, SIDE, 4)} float64"
    assert TABLE <= peak <= TABLE + SLACK, peak / TABLE  # was 5 tables


def with_empty_entries(path, entries):
    """A valid 3x3 table file with ``entries`` empty zip entries after its arrays."""
    save_q_table(path, np.zeros((3, 3, 3, 3, 4)), metadata(3))
    with zipfile.ZipFile(path, "a") as archive:
        for n in range(entries):
            archive.writestr(f"{n}", b"")
    return path


def test_a_table_with_many_empty_entries_is_refused_before_its_directory_is_read(tmp_path, warm_up):
    path = with_empty_entries(tmp_path / "q.npz", 20_000)  # 11 MiB of zipfile's objects, before
    peak, outcome = peak_of_loading(path, warm_up)
    assert outcome == f"{path}: holds 20,002 entries; expected only 'metadata.npy' and 'q.npy'"
    assert peak <= table_bytes(3, 3) + SLACK


def test_one_unexpected_entry_is_refused(tmp_path):
    path = with_empty_entries(tmp_path / "q.npz", 1)
    with pytest.raises(QTableError, match=r"holds 3 entries; expected only 'metadata\.npy'"):
        load_q_table(path)
    path = tmp_path / "renamed.npz"
    save_q_table(path, np.zeros((3, 3, 3, 3, 4)), metadata(3))
    path.write_bytes(path.read_bytes().replace(b"metadata.npy", b"metadata.txt"))
    with pytest.raises(QTableError, match=r"holds an unexpected entry 'metadata\.txt'"):
        load_q_table(path)


def end_record(data):
    """Where the end record of the zip file ``data`` starts, and its fields."""
    at = data.rindex(b"PK\x05\x06")
    return at, list(struct.unpack("<4s4H2LH", data[at : at + 22]))


def test_end_records_that_understate_the_directory_are_refused(tmp_path):
    path = with_empty_entries(tmp_path / "q.npz", 2_000)
    data = bytearray(path.read_bytes())
    at, fields = end_record(data)
    fields[3:5] = [2, 2]  # two entries, but the directory holds 2,002
    data[at : at + 22] = struct.pack("<4s4H2LH", *fields)
    path.write_bytes(bytes(data))
    with pytest.raises(QTableError, match=r"has a zip directory of [\d,]+ bytes, more than"):
        load_q_table(path)


def test_a_zip64_end_record_is_checked_too(tmp_path):
    path = tmp_path / "q.npz"
    save_q_table(path, np.zeros((3, 3, 3, 3, 4)), metadata(3))
    data = path.read_bytes()
    at, fields = end_record(data)
    directory = fields[6]
    record64 = struct.pack(
        "<4sQ2H2L4Q", b"PK\x06\x06", 44, 45, 45, 0, 0, 5_000_000, 5_000_000, fields[5], directory
    )
    locator = struct.pack("<4sLQL", b"PK\x06\x07", 0, at, 1)
    path.write_bytes(data[:at] + record64 + locator + data[at:])
    with pytest.raises(QTableError, match="holds 5,000,000 entries"):
        load_q_table(path)


def test_a_corrupt_table_is_refused_after_reading_it_in_chunks(tmp_path):
    path = tmp_path / "q.npz"
    q = np.random.default_rng(0).random((6, 6, 6, 6, 4))  # 41 KB: no compression
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as archive:
        buffer = io.BytesIO()
        np.lib.format.write_array(buffer, q)
        archive.writestr("q.npy", buffer.getvalue())
        buffer = io.BytesIO()
        np.lib.format.write_array(buffer, np.array(json.dumps(metadata(6))))
        archive.writestr("metadata.npy", buffer.getvalue())
    assert np.array_equal(load_q_table(path)[0], q)
    data = bytearray(path.read_bytes())
    data[data.index(b"PK\x03\x04") + 30 + len("q.npy") + 200] ^= 0xFF  # a byte of the table
    path.write_bytes(bytes(data))
    with pytest.raises(QTableError, match=r"truncated or corrupt .*Bad CRC-32"):
        load_q_table(path)


@pytest.mark.parametrize("dtype", [">f8", "<f4", "<f2", np.longdouble])
@pytest.mark.parametrize("order", ["C", "F"])
def test_every_real_float_type_and_order_loads_as_the_same_float64_table(tmp_path, dtype, order):
    path = tmp_path / "q.npz"
    exact = np.random.default_rng(1).integers(-99, 99, (5, 4, 5, 4, 4)) / 4  # exact in float16
    stored = np.asarray(exact, dtype=dtype, order=order)
    text = json.dumps(metadata(5) | {"grid_cols": 4}, sort_keys=True)
    np.savez_compressed(path, q=stored, metadata=np.array(text))
    q, _ = load_q_table(path)
    assert q.dtype == np.float64
    assert np.array_equal(q, exact)


def test_the_largest_metadata_loads_within_the_bound(tmp_path, warm_up):
    meta = metadata(3)
    room = 2**18 - len(json.dumps(meta, sort_keys=True)) - 10  # 1 MiB less 40 bytes in the file
    meta["package_version"] = "x" * room
    path = tmp_path / "q.npz"
    np.savez_compressed(path, q=np.zeros((3, 3, 3, 3, 4)), metadata=np.array(json.dumps(meta)))
    peak, outcome = peak_of_loading(path, warm_up)
    assert outcome == f"loaded {(3, 3, 3, 3, 4)} float64"
    assert peak <= table_bytes(3, 3) + SLACK  # was 2.4 MiB: the data, a copy, two strings


@pytest.mark.parametrize("byteorder", ["<", ">"])
def test_metadata_is_read_as_ascii_in_either_byte_order(tmp_path, byteorder):
    path = tmp_path / "q.npz"
    text = json.dumps(metadata(3))
    stored = np.array(text, dtype=f"{byteorder}U{len(text) + 3}")  # trailing NULs, dropped
    np.savez_compressed(path, q=np.zeros((3, 3, 3, 3, 4)), metadata=stored)
    assert load_q_table(path)[1] == metadata(3)
    text = text.replace('"seed": 0', '"seed": 0, "note": "caf\u00e9"')
    np.savez_compressed(path, q=np.zeros((3, 3, 3, 3, 4)), metadata=np.array(text))
    with pytest.raises(QTableError, match="array 'metadata' holds characters other than ASCII"):
        load_q_table(path)


PEAK_OF_SAVING = textwrap.dedent(
    """
    import gc, json, sys
    import numpy as np
    from warehouse_phys.rl.qlearning import QLearningConfig, make_table_metadata, save_q_table
    from warehouse_phys.world.grid import WarehouseGrid

    def status(field):
        with open("/proc/self/status") as lines:
            for line in lines:
                if line.startswith(field + ":"):
                    return int(line.split()[1]) * 1024

    side = int(sys.argv[2])
    metadata = make_table_metadata("warehouse-robot-v0", WarehouseGrid(side, side),
                                   QLearningConfig())
    save_q_table(sys.argv[1], np.zeros((3, 3, 3, 3, 4)), make_table_metadata(
        "warehouse-robot-v0", WarehouseGrid(3, 3), QLearningConfig()))  # every path once
    # A table as large as training's, of one value: a copy of it is as resident as a copy
    # of any other, and it compresses in a second rather than ten (random values).
    q = np.full((side, side, side, side, 4), 0.5)
    gc.collect()
    with open("/proc/self/clear_refs", "w") as clear:
        clear.write("5")
    before = status("VmRSS")
    save_q_table(sys.argv[1], q, metadata)
    print(json.dumps({"peak": status("VmHWM") - before}))
    """
)


def test_saving_a_table_makes_no_copy_of_it(tmp_path):
    """``train --env grid --rows 90 --cols 90`` trains a 2,002 MiB table within the 2 GiB
    budget; its save made a whole float64 copy (3.4 GB at the peak). The save now writes
    the table a chunk at a time (numpy's 16 MiB, a few buffers of it at once: 64 MB
    whatever the table): measured on a 50 x 50 table (200 MB)."""
    side = 50
    result = subprocess.run(
        [sys.executable, "-c", PEAK_OF_SAVING, str(tmp_path / "q.npz"), str(side)],
        capture_output=True, text=True, timeout=300, check=True,
    )  # fmt: skip
    peak = json.loads(result.stdout)["peak"]
    assert peak < table_bytes(side, side) / 2, peak / table_bytes(side, side)  # was above 1
