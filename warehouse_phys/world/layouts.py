"""Warehouse layouts: the presets, and turning a ``layout=`` argument into a grid.

A layout is text, one string per row: ``.`` floor, ``#`` shelf, ``P`` floor on
which packages may appear, ``S`` a start (the first is the robot's; a fleet uses all; see
:meth:`warehouse_phys.world.grid.WarehouseGrid.from_layout`). Each preset is
registered as ``warehouse-robot-<name>-v0`` (grid twin) and
``warehouse-robot-phys-<name>-v0`` (physics-backed), with a time limit that
suits its size. Like :mod:`warehouse_phys.world.grid`, this module imports neither
gymnasium, pymunk nor pygame.

Fleet floors: :func:`warehouse` generates Kiva-style warehouses (rows of shelf
blocks with aisles between), and :data:`FLEET_PRESETS` names one, ``"warehouse"``,
whose floor equals the classic ``kiva-33-46.map`` of the multi-robot planning
benchmarks cell for cell. Benchmark maps in the MovingAI format are read by
:func:`read_movingai` (and wherever a ``layout=`` takes a path ending in ``.map``)
and written by :func:`write_movingai`.

Its length is the MovingAI reader's one-line errors for every malformed file, beside
the presets and the warehouse generator: one module for every way a floor is made.
"""

from __future__ import annotations

import os
import re
import stat
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from warehouse_phys.files.atomic import atomic_write_text
from warehouse_phys.world.grid import DEFAULT_COLS, DEFAULT_ROWS, WarehouseGrid, refuse_durations
from warehouse_phys.world.layout_text import MAX_SIDE, check_size


@dataclass(frozen=True)
class Preset:
    """A named layout and the time limit of its registered environments."""

    name: str
    rows: tuple[str, ...]
    #: Time limit of the registered ids: :func:`suggested_time_limit`, within
    #: which a uniformly random walk reaches the package in at least 98 % of
    #: episodes, as on the default floor with its 200 steps.
    max_episode_steps: int
    #: Episodes with which the default trainer's greedy policy reaches every
    #: package by a shortest path (checked for several seeds by the tests).
    training_episodes: int
    description: str


PRESETS: dict[str, Preset] = {
    preset.name: preset
    for preset in (
        Preset(
            name="aisles",
            rows=(
                "S........",
                ".###.###.",
                ".........",
                ".###.###.",
                ".........",
                ".###.###.",
                ".........",
            ),
            max_episode_steps=1200,
            training_episodes=15_000,
            description="three rows of shelves with picking aisles between them; "
            "packages anywhere on the floor",
        ),
        Preset(
            name="depot",
            rows=(
                "S.......",
                ".##.###.",
                ".##.###.",
                "........",
                "##.##.##",
                "PP.PP.PP",
            ),
            max_episode_steps=1500,
            training_episodes=1000,
            description="storage shelves above a loading bay; packages wait at the six "
            "docks of the bay, reached through gaps in the bay's wall",
        ),
        Preset(
            name="maze",
            rows=(
                "S.#....",
                "..#.##.",
                "..#..#.",
                "....##.",
                "###....",
            ),
            max_episode_steps=900,
            training_episodes=5000,
            description="a small store room whose shelves force detours",
        ),
    )
}


#: The share of uniformly random episodes a time limit lets reach the package.
TIME_LIMIT_FINISH_RATE = 0.98
#: Floors with at most this many reachable cells get the exact random-walk limit.
EXACT_TIME_LIMIT_CELLS = 100
#: Time limit per reachable cell of a larger floor [steps/cell]: what the exact
#: limit comes to on open floors from 6 x 6 to 14 x 14 (11 to 12).
TIME_LIMIT_STEPS_PER_CELL = 12


def suggested_time_limit(grid: WarehouseGrid, granularity: int = 100) -> int:
    """A time limit for episodes on ``grid``, in whole ``granularity`` steps.

    On a floor of at most :data:`EXACT_TIME_LIMIT_CELLS` reachable cells it is
    the shortest limit within which a uniformly random walk reaches the package
    in at least 98 % of episodes, computed exactly: what the default floor's
    200 steps give (98.6 %), and how the presets' limits were chosen. Long
    enough for epsilon-greedy exploration to find the package early in
    training, short enough not to waste time.

    That exact limit grows like ``n log n`` with the ``n`` cells and costs far
    more to compute, so a larger floor gets :data:`TIME_LIMIT_STEPS_PER_CELL`
    steps per reachable cell instead (rounded up to ``granularity``): what the
    exact rule gives on open floors up to 14 x 14. It takes no time to compute.
    """
    if isinstance(granularity, bool) or not isinstance(granularity, int) or granularity < 1:
        raise ValueError(f"granularity must be a positive integer, got {granularity!r}")
    cells = len(grid.reachable)
    if cells > EXACT_TIME_LIMIT_CELLS:
        return -(-TIME_LIMIT_STEPS_PER_CELL * cells // granularity) * granularity
    return grid.random_walk_time_limit(TIME_LIMIT_FINISH_RATE, granularity)


def preset_name(rows: Sequence[str]) -> str | None:
    """The name of the preset whose layout is ``rows``, or ``None``."""
    for preset in PRESETS.values():
        if tuple(rows) == preset.rows:
            return preset.name
    return None


def preset_ids(name: str) -> tuple[str, str]:
    """The registered ids of preset ``name``: ``(grid twin, physics-backed)``."""
    return f"warehouse-robot-{name}-v0", f"warehouse-robot-phys-{name}-v0"


def resolve_layout(layout: str | os.PathLike[str] | Sequence[str]) -> WarehouseGrid:
    """The grid of a preset name (:data:`PRESETS` or :data:`FLEET_PRESETS`), of a MovingAI
    map file (a path ending in ``.map``) or of a layout's rows.

    Raises:
        ValueError: for an unknown preset name, an unreadable or malformed map file or
            an invalid layout (the message says which, and where).
        TypeError: if ``layout`` is neither a string, a path nor a sequence of strings.
    """
    if isinstance(layout, os.PathLike) or (isinstance(layout, str) and layout.endswith(".map")):
        return read_movingai(layout)
    if isinstance(layout, str):
        if layout in FLEET_PRESETS:
            return WarehouseGrid.from_layout(FLEET_PRESETS[layout])
        preset = PRESETS.get(layout)
        if preset is None:
            names = ", ".join(sorted([*PRESETS, *FLEET_PRESETS]))
            raise ValueError(
                f"unknown layout preset {layout!r}; presets: {names} (or pass the rows as a "
                "list of strings, or a MovingAI .map file)"
            )
        return WarehouseGrid.from_layout(preset.rows)
    return WarehouseGrid.from_layout(layout)


def warehouse(
    shelf_rows: int = 8,
    blocks_per_row: int = 3,
    block_length: int = 10,
    aisle_width: int = 3,
    gap_width: int = 1,
    margin_rows: int = 2,
    margin_cols: int = 7,
) -> tuple[str, ...]:
    """A Kiva-style warehouse floor, as layout rows: ``shelf_rows`` rows of shelves, each
    ``blocks_per_row`` blocks of ``block_length`` shelf cells with ``gap_width`` free
    columns between blocks, ``aisle_width`` free rows between shelf rows, and free
    margins of ``margin_rows`` rows above and below and ``margin_cols`` columns left and
    right. No start is marked (a fleet draws its starts) and every free cell may hold a
    package; the free cells are always connected. The defaults give the classic 33 x 46
    floor of ``kiva-33-46.map``.

    Raises:
        TypeError: naming the argument, if one is not an integer.
        ValueError: naming the argument, if one is out of range, the floor would exceed
            the largest floor, or the margins would leave shelves walling off the floor.
    """
    sizes = {"shelf_rows": shelf_rows, "blocks_per_row": blocks_per_row,
             "block_length": block_length, "aisle_width": aisle_width, "gap_width": gap_width,
             "margin_rows": margin_rows, "margin_cols": margin_cols}  # fmt: skip
    for name, value in sizes.items():
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"{name} must be an integer, got {value!r}")
        least = 1 if name in ("shelf_rows", "blocks_per_row", "block_length", "aisle_width",
                              "gap_width") else 0  # fmt: skip
        if value < least:
            raise ValueError(f"{name} must be at least {least}, got {value}")
    height = 2 * margin_rows + shelf_rows + (shelf_rows - 1) * aisle_width
    width = 2 * margin_cols + blocks_per_row * block_length + (blocks_per_row - 1) * gap_width
    if height > MAX_SIDE or width > MAX_SIDE:
        raise ValueError(
            f"the warehouse would be {height} x {width} cells; the largest floor is "
            f"{MAX_SIDE} x {MAX_SIDE}"
        )
    if height < 2:  # one row of shelves: the gaps between blocks are cut off
        raise ValueError(
            "margin_rows must be at least 1 when shelf_rows is 1: the warehouse would be a "
            "single row of shelves"
        )
    if blocks_per_row == 1 and margin_cols == 0:  # each row of shelves a wall
        raise ValueError(
            "margin_cols must be at least 1 when blocks_per_row is 1: each row of shelves "
            "would wall off the aisles from one another"
        )
    free = "." * width
    blocks = ("." * gap_width).join(["#" * block_length] * blocks_per_row)
    shelves = "." * margin_cols + blocks + "." * margin_cols
    rows = [free] * margin_rows
    for i in range(shelf_rows):
        rows += [free] * (aisle_width if i else 0) + [shelves]
    rows += [free] * margin_rows
    return tuple(rows)


#: Floors for fleets, by name: larger than single-robot training suits, so they are not
#: registered as single-robot environments; every ``layout=`` takes their names.
FLEET_PRESETS: dict[str, tuple[str, ...]] = {
    # The classic Kiva warehouse of the planning benchmarks (kiva-33-46.map): 192 robots,
    # 256 steps, lifelong is where published fleets are compared.
    "warehouse": warehouse(),
}

#: MovingAI map symbols: the passable and the blocked ones.
MOVINGAI_PASSABLE = frozenset(".GSE")
MOVINGAI_BLOCKED = frozenset("@OTW")
#: The endpoint symbol: package cells with ``packages="endpoints"``.
MOVINGAI_ENDPOINT = "E"
#: Most bytes read for a map's four header lines, before the map's size is known.
MAX_HEADER_BYTES = 1 << 16
#: Bytes a map file may hold beyond its header and its rows (each row's symbols and a
#: ``"\r\n"``): blank lines and stray spaces at its end.
MAP_SLACK_BYTES = 4096
#: Largest map file read [bytes]: the largest floor's rows, a header and the slack.
MAX_MAP_BYTES = MAX_HEADER_BYTES + (MAX_SIDE + 2) * MAX_SIDE + MAP_SLACK_BYTES
_HEADER = ("type", "height", "width", "map")


def read_movingai(path: str | os.PathLike[str], packages: str = "all") -> WarehouseGrid:
    """The floor of a MovingAI ``.map`` file.

    The header is ``type <name>``, ``height H``, ``width W``, ``map``, then come ``H``
    rows of ``W`` symbols: passable ``.``, ``G``, ``S`` (swamp) and ``E`` (endpoint),
    blocked ``@``, ``O``, ``T`` and ``W`` (shelves here). ``packages="all"`` (default,
    POGEMA's convention) lets packages appear on every free cell of the start's region
    but the start itself (the single robot's start is never a package cell; free cells
    cut off from it are never reached); ``"endpoints"`` only on ``E`` cells, which must
    then all lie in one region. Maps of 1 to :data:`~warehouse_phys.world.grid.MAX_SIDE`
    cells a side are read (sizes may have leading zeros); the header is read first, and
    a file longer than a map of the header's size can be is refused. No start is marked
    (``starts_marked`` is False): a fleet
    draws its starts, and the single robot starts on the first cell in reading order of the
    largest free region (with ``"endpoints"``: of the largest region holding an ``E``,
    on its first cell that is not an ``E``), as
    :meth:`~warehouse_phys.world.grid.WarehouseGrid.from_layout` does for rows without ``S``.

    Raises:
        TypeError: if ``path`` is not a ``str`` or an ``os.PathLike`` of one (a ``bytes``
            path, say).
        ValueError: one line naming the file (quoted if its name holds a control character)
            and the line, or the map's lines for faults of the whole floor, for a path that
            is missing, a folder, a pipe or a device, a file that is unreadable, binary or
            longer than its header's size allows, a bad header, rows of the wrong number or
            length, an unknown symbol, no free cell, no endpoint with
            ``packages="endpoints"``, or an unknown ``packages``.
    """
    if not isinstance(path, (str, os.PathLike)) or not isinstance(os.fspath(path), str):
        raise TypeError(
            f"path must be a str or an os.PathLike of a str (a map file's path), got "
            f"{type(path).__name__}"
        )
    if packages not in ("all", "endpoints"):
        raise ValueError(f"packages must be 'all' or 'endpoints', got {packages!r}")
    name, text, (height, width) = _map_text(Path(path))
    lines = _text_lines(text)
    body = lines[len(_HEADER) :]
    while body and len(body) > height and not body[-1].strip():
        body.pop()  # blank lines at the end
    if len(body) != height:
        raise ValueError(
            f"{name}, line {len(_HEADER) + min(len(body), height) + 1}: the header says "
            f"{height} {'row' if height == 1 else 'rows'}, the file has {len(body)}"
        )
    rows = _map_rows(name, body, width, packages)
    # Errors about the whole floor name the map's lines, and its rows as cells count them.
    first, last = len(_HEADER) + 1, len(_HEADER) + height
    where = f"{name}, line {first}" if height == 1 else f"{name}, lines {first}-{last}"
    where += f" (map rows 0-{height - 1})" if height > 1 else " (map row 0)"
    if packages == "endpoints" and not any(MOVINGAI_ENDPOINT in row for row in body):
        raise ValueError(f"{where}: packages='endpoints' but the map marks no 'E' cell")
    try:
        return WarehouseGrid.from_layout(rows)
    except ValueError as error:
        raise ValueError(f"{where}: {error}") from None


def _text_lines(text: str) -> list[str]:
    """The lines of a map's text. Lines end at "\\n" only (and a "\\r" before it is
    dropped): str.splitlines would also end them at form feeds and other controls, which
    then could not be reported as symbols."""
    lines = [line.removesuffix("\r") for line in text.split("\n")]
    if lines[-1] == "":
        lines.pop()  # the last line's end
    return lines


def _map_text(path: Path) -> tuple[str, str, tuple[int, int]]:
    """The name messages give ``path`` by, the text of its file and the header's height
    and width, or the :func:`read_movingai` ``ValueError`` of a file that is no map's text.

    The header is read first, so that a file too long for its map is refused with the
    header's size, and no more than that map's bytes are ever read."""
    # The file's name as messages give it: quoted if it holds a line end or another control.
    name = str(path) if str(path).isprintable() else repr(str(path))
    if "\0" in str(path):
        raise ValueError(f"{name}: a path with a NUL character, not a map file")
    try:
        status = path.stat()
        # A pipe or a device: opening a pipe waits for a writer, a device may never end.
        special = not stat.S_ISREG(status.st_mode) and not stat.S_ISDIR(status.st_mode)
        if not special:
            with path.open("rb") as file:
                # A UTF-8 byte order mark, as some editors add, is dropped first.
                data = file.read(MAX_HEADER_BYTES).removeprefix(b"\xef\xbb\xbf")
                header = _header_bytes(name, data)
                size = _map_size(name, _text_lines(_ascii(name, header)))
                limit = len(header) + size[0] * (size[1] + 2) + MAP_SLACK_BYTES
                data += file.read(max(0, limit + 1 - len(data)))  # one byte past: too long
    except FileNotFoundError:
        raise ValueError(f"{name}: no such map file") from None
    except IsADirectoryError:
        raise ValueError(f"{name}: a folder, not a map file") from None
    except OSError as error:
        raise ValueError(f"{name}: cannot read the map: {error.strerror or error}") from None
    if special:
        raise ValueError(f"{name}: not a regular file (a pipe or a device), not a map file")
    if len(data) > limit:
        raise ValueError(
            f"{name}: {max(status.st_size, len(data)):,} bytes, longer than a map of "
            f"{size[0]} x {size[1]} cells (the header's height x width) can be: at most "
            f"{limit:,} bytes"
        )
    return name, _ascii(name, data), size


def _header_bytes(name: str, data: bytes) -> bytes:
    """The bytes of the header's lines at the start of ``data`` (all of it if the file ends
    first), or the ``ValueError`` of a header longer than :data:`MAX_HEADER_BYTES`."""
    end = 0
    for _ in _HEADER:
        found = data.find(b"\n", end)
        if found < 0:
            if len(data) < MAX_HEADER_BYTES:  # the file ends within the header
                return data
            raise ValueError(
                f"{name}: the header's {len(_HEADER)} lines are longer than "
                f"{MAX_HEADER_BYTES:,} bytes; not a MovingAI map"
            )
        end = found + 1
    return data[:end]


def _ascii(name: str, data: bytes) -> str:
    """``data`` (a map file's first bytes) as text, or a ``ValueError`` naming the line
    and column of its first byte that is not ASCII."""
    try:
        return data.decode("ascii")
    except UnicodeDecodeError as error:
        line = data[: error.start].count(b"\n") + 1
        column = error.start - (data.rfind(b"\n", 0, error.start) + 1) + 1
        raise ValueError(
            f"{name}, line {line}, column {column}: byte {data[error.start]:#04x} is not ASCII "
            "text; not a MovingAI map"
        ) from None


def _map_size(name: str, lines: list[str]) -> tuple[int, int]:
    """The ``height`` and ``width`` of a map's header lines, or a ``ValueError`` naming the line."""
    sizes = {}
    for number, key in enumerate(_HEADER, start=1):
        words = lines[number - 1].split() if number <= len(lines) else []
        if not words or words[0] != key or len(words) != (1 if key == "map" else 2):
            got = repr(lines[number - 1][:40]) if number <= len(lines) else "the end of the file"
            expected = "'map'" if key == "map" else f"'{key} <value>'"
            raise ValueError(f"{name}, line {number}: expected {expected}, got {got}")
        if key in ("height", "width"):
            number_match = re.fullmatch(r"([+-]?)0*([0-9]+)", words[1])  # leading zeros dropped
            if not number_match:
                raise ValueError(
                    f"{name}, line {number}: {key} must be an integer, got {words[1][:40]!r}"
                )
            sign, digits = number_match.groups()
            # More digits than any size has: out of range (int() would refuse 4,300 digits).
            size = int(digits) if len(digits) <= 12 else MAX_SIDE + 1
            sizes[key] = -size if sign == "-" else size
            if not 1 <= sizes[key] <= MAX_SIDE:
                raise ValueError(f"{name}, line {number}: {key} must be 1 to {MAX_SIDE} (the "
                                 f"largest floor), got {words[1][:40]}")  # fmt: skip
    return sizes["height"], sizes["width"]


def _map_rows(name: str, body: list[str], width: int, packages: str) -> list[str]:
    """A map's rows in layout symbols (``#`` blocked, ``.`` free, ``P`` an endpoint with
    ``packages="endpoints"``), or a ``ValueError`` naming the line and column."""
    known = MOVINGAI_PASSABLE | MOVINGAI_BLOCKED
    endpoint = "P" if packages == "endpoints" else "."
    table = str.maketrans({**dict.fromkeys(MOVINGAI_BLOCKED, "#"),
                           **dict.fromkeys(".GS", "."), MOVINGAI_ENDPOINT: endpoint})  # fmt: skip
    rows = []
    for number, row in enumerate(body, start=len(_HEADER) + 1):
        if len(row) != width:
            raise ValueError(
                f"{name}, line {number}: a row of {len(row)} symbols; the header says {width}"
            )
        if not set(row) <= known:
            column = next(i for i, symbol in enumerate(row) if symbol not in known)
            raise ValueError(
                f"{name}, line {number}, column {column + 1}: unknown symbol {row[column]!r}; "
                f"passable {''.join(sorted(MOVINGAI_PASSABLE))}, blocked "
                f"{''.join(sorted(MOVINGAI_BLOCKED))}"
            )
        rows.append(row.translate(table))
    return rows


def write_movingai(grid: WarehouseGrid, path: str | os.PathLike[str]) -> Path:
    """Save ``grid`` as a MovingAI ``.map`` file (``type octile``), atomically; returns the
    path.

    Shelves are ``@`` and floor ``.``. The format has no start, so a floor is read back
    with its start chosen as for any map (see :func:`read_movingai`). When that floor,
    read with ``packages="all"``, would have other package cells than ``grid`` (packages
    on some cells only, or a start elsewhere), the package cells are written as ``E``, and
    ``read_movingai(path, packages="endpoints")`` gives the same shelves and package
    cells (its start is the first floor cell of the packages' region that is not a
    package cell). Read the file with ``packages="endpoints"`` when it has an ``E``,
    ``"all"`` otherwise, and the floor round-trips.
    """
    # Whole rows at a time, as bytes: a 2,048 x 2,048 floor takes no loop over its cells.
    plain = np.where(grid.shelf_mask, ord("#"), ord(".")).astype(np.uint8)
    try:
        again = WarehouseGrid.from_layout([row.tobytes().decode("ascii") for row in plain])
        endpoints = not np.array_equal(again.target_indices, grid.target_indices)
    except ValueError:  # a floor of one reachable cell: packages="all" leaves no package
        endpoints = True
    symbols = np.where(grid.shelf_mask, ord("@"), ord(".")).astype(np.uint8)
    if endpoints:
        symbols.flat[grid.target_indices] = ord(MOVINGAI_ENDPOINT)
    lines = np.concatenate([symbols, np.full((grid.rows, 1), ord("\n"), np.uint8)], axis=1)
    header = f"type octile\nheight {grid.rows}\nwidth {grid.cols}\nmap\n"
    return atomic_write_text(path, header + lines.tobytes().decode("ascii"))


def make_grid(
    grid_rows: int | None, grid_cols: int | None, layout: str | Sequence[str] | None
) -> WarehouseGrid:
    """The empty ``grid_rows`` x ``grid_cols`` floor (by default
    :data:`~warehouse_phys.world.grid.DEFAULT_ROWS` x
    :data:`~warehouse_phys.world.grid.DEFAULT_COLS`), or the layout's."""
    refuse_durations(grid_rows=grid_rows, grid_cols=grid_cols)
    if layout is None:
        return WarehouseGrid(
            DEFAULT_ROWS if grid_rows is None else grid_rows,
            DEFAULT_COLS if grid_cols is None else grid_cols,
        )
    for name, given in (("grid_rows", grid_rows), ("grid_cols", grid_cols)):
        if given is not None:
            check_size(name, given)
    grid = resolve_layout(layout)
    for name, given, actual in (
        ("grid_rows", grid_rows, grid.rows),
        ("grid_cols", grid_cols, grid.cols),
    ):
        if given is not None and given != actual:
            raise ValueError(f"{name}={given} contradicts the layout, which has {actual}")
    return grid
