"""A floor drawn as text, and the size any floor may have, checked with one-line errors.

The symbols of a layout (:data:`LAYOUT_SYMBOLS`), the checks of its rows
(:func:`checked_layout`), the start of a layout that marks none (:func:`unmarked_start`),
the cells where packages may appear (:func:`package_cells`) and the limits on a floor's
rows and columns (:data:`MIN_SIDE`, :data:`MAX_SIDE`, :func:`check_size`):
:meth:`~warehouse_phys.world.grid.WarehouseGrid.from_layout` composes them.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from warehouse_phys.world.cells import Cell, CellSequence

if TYPE_CHECKING:
    from warehouse_phys.world.grid import WarehouseGrid

#: Fewest rows and columns of a floor [cells]: the target sits outside row 0 and column 0.
MIN_SIDE = 2
#: Most rows and columns of a floor [cells]: the largest maps of the League of Robot
#: Runners (1,912 x 1,800) fit. The world model keeps about 17 bytes a cell (three masks
#: and a row of bytes for moves, a byte each, 8 bytes per package cell and the layout's
#: text), so a 2,048 x 2,048 floor builds in about 0.1 s and holds about 70 MB.
MAX_SIDE = 2048

#: The symbols of a layout's text, one character per cell.
FLOOR, SHELF, PACKAGE, START = ".", "#", "P", "S"
LAYOUT_SYMBOLS = {
    FLOOR: "floor",
    SHELF: "shelf",
    PACKAGE: "floor where packages may appear",
    START: "a robot's start (floor); the first is the single robot's, a fleet uses all",
}

#: Most cells an error message lists; the rest are counted.
LISTED_CELLS = 5

#: Any character that is no layout symbol.
_UNKNOWN_SYMBOL = re.compile(f"[^{re.escape(''.join(LAYOUT_SYMBOLS))}]")


def checked_layout(layout: Sequence[str]) -> tuple[list[str], np.ndarray]:
    """The rows of ``layout`` and its symbols as a ``(rows, cols)`` uint8 array of their
    ASCII codes, or the ``TypeError``/``ValueError`` of :meth:`WarehouseGrid.from_layout`
    naming what is wrong and where (checked a whole row or floor at a time, not per cell)."""
    if isinstance(layout, str) or not isinstance(layout, Sequence):
        raise TypeError(f"a layout is a list of strings, one per row, got {type(layout).__name__}")
    rows = list(layout)
    if not rows or not all(isinstance(row, str) for row in rows):
        raise TypeError("a layout is a non-empty list of strings, one per row")
    width = len(rows[0])
    if width == 0:
        raise ValueError("layout row 0 is empty")
    if len(rows) > MAX_SIDE or width > MAX_SIDE:
        raise ValueError(
            f"the layout has {len(rows)} rows of {width} cells: the largest floor is "
            f"{MAX_SIDE} x {MAX_SIDE} cells"
        )
    uneven = next((r for r, row in enumerate(rows) if len(row) != width), len(rows))
    # Rows are read in order, so an unknown symbol above the first uneven row comes first.
    unknown = _UNKNOWN_SYMBOL.search("".join(rows[:uneven]))
    if unknown:
        r, c = divmod(unknown.start(), width)
        known = ", ".join(f"{k!r} {v}" for k, v in LAYOUT_SYMBOLS.items())
        raise ValueError(
            f"unknown layout symbol {unknown.group()!r} at row {r}, column {c}; known: {known}"
        )
    if uneven < len(rows):
        raise ValueError(
            f"layout rows must all have the same length: row {uneven} has "
            f"{len(rows[uneven])} cells, row 0 has {width}"
        )
    # Every symbol is ASCII now, so one byte is one cell.
    symbols = np.frombuffer("".join(rows).encode("ascii"), dtype=np.uint8)
    return rows, symbols.reshape(len(rows), width)


def package_cells(grid: WarehouseGrid, symbols: np.ndarray) -> np.ndarray:
    """The indices of the cells of a layout's floor where packages may appear: its ``P``
    cells off the starts, or every cell the robot reaches off the starts; refused if
    there are none."""
    marked = symbols == ord(PACKAGE)
    starts = np.zeros(symbols.shape, dtype=bool)
    starts[tuple(np.array(grid.starts).T)] = True
    if marked.any():
        unreachable = np.flatnonzero(marked & ~grid.reachable_mask)
        if unreachable.size:
            cells = CellSequence(unreachable, grid.rows, grid.cols)
            raise ValueError(
                f"package cells {cell_list(cells)} cannot be reached from the start "
                f"{tuple(grid.start)}"
            )
        targets = np.flatnonzero(marked & ~starts)
    else:
        targets = np.flatnonzero(grid.reachable_mask & ~starts)
    if not targets.size:
        raise ValueError(
            f"the layout leaves no cell for the package: no floor other than the start "
            f"{tuple(grid.start)} can be reached"
        )
    return targets


def cell_list(cells: Sequence[tuple[int, int]]) -> str:
    """``cells`` as a list for an error message: the first :data:`LISTED_CELLS`, then how
    many there are in all, so that a message stays one short line on any floor."""
    shown = ", ".join(str(tuple(cell)) for cell in cells[:LISTED_CELLS])
    more = f", ... ({len(cells)} in all)" if len(cells) > LISTED_CELLS else ""
    return f"[{shown}{more}]"


def unmarked_start(symbols: np.ndarray, regions: np.ndarray, count: int) -> Cell:
    """The start of a layout that marks none: the first cell, in reading order, of the
    largest region of free cells connected by moves (the first such region on a tie).
    When the layout marks package cells, only the regions holding one compete, and the
    start is the region's first cell that is not a package cell (if it has one).
    ``regions`` numbers the regions in reading order, 1 to ``count`` (0 on shelves)."""
    if count == 0:
        raise ValueError("the layout has no floor: every cell is a shelf")
    sizes = np.bincount(regions.ravel(), minlength=count + 1)
    packages = symbols == ord(PACKAGE)
    candidates = np.unique(regions[packages]) if packages.any() else np.arange(1, count + 1)
    chosen = candidates[int(sizes[candidates].argmax())]  # ascending: the first on a tie
    region = regions.ravel() == chosen
    plain = region & ~packages.ravel()
    first = int(np.flatnonzero(plain if plain.any() else region)[0])
    return Cell(*divmod(first, symbols.shape[1]))


def check_size(name: str, value: object) -> int:
    """``value`` as a number of rows or columns, or a ``TypeError``/``ValueError`` naming ``name``.

    A floor has at least :data:`MIN_SIDE` rows and columns (the target is placed
    outside row 0 and column 0) and at most :data:`MAX_SIDE`.
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    if value < MIN_SIDE:
        raise ValueError(
            f"{name} must be at least {MIN_SIDE}, got {value}: the target is placed in rows "
            "1..R-1 and columns 1..C-1, so a grid needs at least 2 rows and 2 columns"
        )
    if value > MAX_SIDE:
        raise ValueError(
            f"{name} must be at most {MAX_SIDE}, got {value}: the largest floor is "
            f"{MAX_SIDE} x {MAX_SIDE} cells"
        )
    return int(value)
