"""MovingAI ``.map`` files, the benchmark maps' format: read as a floor, written from one.

The header is ``type <name>``, ``height H``, ``width W``, ``map``, then come ``H`` rows of
``W`` symbols: passable ``.``, ``G``, ``S`` (swamp) and ``E`` (endpoint), blocked ``@``,
``O``, ``T`` and ``W``. :func:`read_movingai` reads the header first and the ``H`` rows
after it, as the League of Robot Runners' own reader does: lines after them are ignored
with a ``UserWarning`` (some of the competition's files hold their map twice). Every
malformed file is refused in one line naming the file and the line. :func:`write_movingai`
saves any floor as such a file, atomically. Like :mod:`warehouse_phys.world.grid`, this
module imports neither gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

import os
import re
import stat
import warnings
from pathlib import Path

import numpy as np

from warehouse_phys.files.atomic import atomic_write_text
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layout_text import MAX_SIDE

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
#: Largest map [bytes]: the largest floor's rows, a header and the slack.
MAX_MAP_BYTES = MAX_HEADER_BYTES + (MAX_SIDE + 2) * MAX_SIDE + MAP_SLACK_BYTES
#: How many times its map's bytes a file may hold: lines after the rows are read past
#: (and ignored), up to as many bytes again as the map, as in the competition's files that
#: hold their map twice; a longer file is refused before more is read.
MAP_FILE_FACTOR = 2
_HEADER = ("type", "height", "width", "map")


def read_movingai(path: str | os.PathLike[str], packages: str = "all") -> WarehouseGrid:
    """The floor of a MovingAI ``.map`` file.

    The header is ``type <name>``, ``height H``, ``width W``, ``map``, then come ``H``
    rows of ``W`` symbols: passable ``.``, ``G``, ``S`` (swamp) and ``E`` (endpoint),
    blocked ``@``, ``O``, ``T`` and ``W`` (shelves here). Lines after the ``H`` rows are
    ignored, as the competition's reader ignores them, with a ``UserWarning`` naming the
    file and how many lines were ignored (none for blank lines at the end).

    ``packages="all"`` (default, POGEMA's convention) lets packages appear on every free
    cell of the start's region but the start itself (the single robot's start is never a
    package cell; free cells cut off from it are never reached); ``"endpoints"`` only on
    ``E`` cells, which must then all lie in one region. Maps of 1 to
    :data:`~warehouse_phys.world.grid.MAX_SIDE` cells a side are read (sizes may have
    leading zeros); the header is read first, and a file longer than
    :data:`MAP_FILE_FACTOR` times a map of the header's size is refused. No start is
    marked (``starts_marked`` is False): a fleet draws its starts, and the single robot
    starts on the first cell in reading order of the largest free region (with
    ``"endpoints"``: of the largest region holding an ``E``, on its first cell that is not
    an ``E``), as :meth:`~warehouse_phys.world.grid.WarehouseGrid.from_layout` does for
    rows without ``S``.

    Raises:
        TypeError: if ``path`` is not a ``str`` or an ``os.PathLike`` of one (a ``bytes``
            path, say).
        ValueError: one line naming the file (quoted if its name holds a control character)
            and the line, or the map's lines for faults of the whole floor, for a path that
            is missing, a folder, a pipe or a device, a file that is unreadable, binary (in
            its header and rows) or longer than its header's size allows, a bad header, too
            few rows, rows of the wrong length, an unknown symbol, no free cell, no endpoint
            with ``packages="endpoints"``, or an unknown ``packages``.
    """
    if not isinstance(path, (str, os.PathLike)) or not isinstance(os.fspath(path), str):
        raise TypeError(
            f"path must be a str or an os.PathLike of a str (a map file's path), got "
            f"{type(path).__name__}"
        )
    if packages not in ("all", "endpoints"):
        raise ValueError(f"packages must be 'all' or 'endpoints', got {packages!r}")
    name, text, (height, width), after = _map_text(Path(path))
    body = _text_lines(text)[len(_HEADER) :]
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
        grid = WarehouseGrid.from_layout(rows)
    except ValueError as error:
        raise ValueError(f"{where}: {error}") from None
    if after.strip():  # blank lines at the end pass unremarked
        ignored = after.count(b"\n") + (not after.endswith(b"\n"))
        warnings.warn(
            f"{name}: {ignored:,} {'line' if ignored == 1 else 'lines'} after the header's "
            f"{height} {'row' if height == 1 else 'rows'} ignored (as the League of Robot "
            "Runners' reader ignores them)",
            UserWarning,
            stacklevel=2,
        )
    return grid


def _text_lines(text: str) -> list[str]:
    """The lines of a map's text. Lines end at "\\n" only (and a "\\r" before it is
    dropped): str.splitlines would also end them at form feeds and other controls, which
    then could not be reported as symbols."""
    lines = [line.removesuffix("\r") for line in text.split("\n")]
    if lines[-1] == "":
        lines.pop()  # the last line's end
    return lines


def _map_text(path: Path) -> tuple[str, str, tuple[int, int], bytes]:
    """The name messages give ``path`` by, the text of its header and its rows, the
    header's height and width, and the file's bytes after its rows (never decoded); or the
    :func:`read_movingai` ``ValueError`` of a file that is no map's text.

    The header is read first, so that a file too long for its map is refused with the
    header's size, and no more than :data:`MAP_FILE_FACTOR` times that map's bytes are
    ever read."""
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
                limit = (len(header) + size[0] * (size[1] + 2) + MAP_SLACK_BYTES) * MAP_FILE_FACTOR
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
            f"{name}: {max(status.st_size, len(data)):,} bytes, longer than {MAP_FILE_FACTOR} "
            f"maps of {size[0]} x {size[1]} cells (the header's height x width) can be: at "
            f"most {limit:,} bytes"
        )
    end = _rows_end(data, len(header), size[0])
    return name, _ascii(name, data[:end]), size, data[end:]


def _rows_end(data: bytes, start: int, height: int) -> int:
    """Where the ``height`` lines from ``start`` (a map's rows after its header) end in
    ``data``: past the last one's line end, or at the end of ``data`` if it ends first."""
    end = start
    for _ in range(height):
        found = data.find(b"\n", end)
        if found < 0:
            return len(data)
        end = found + 1
    return end


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
