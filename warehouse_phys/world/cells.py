"""Cells of a floor, and read-only views of many of them held as arrays.

A floor of millions of cells cannot keep a Python object per cell. :class:`CellSet` and
:class:`CellSequence` look like the frozenset and the tuple of :class:`Cell` that a small
floor would hold, over a boolean mask or an index array: membership, length, iteration
in reading order, equality with the frozenset or tuple of the same cells. The floor
(:class:`warehouse_phys.world.grid.WarehouseGrid`) builds them; this module knows nothing
of its rules.
"""

from __future__ import annotations

import itertools
import operator
from collections.abc import Iterable, Iterator, Sequence, Set
from typing import Any, NamedTuple, overload

import numpy as np


class Cell(NamedTuple):
    """A cell of the floor; row 0 is the top row, column 0 the left column."""

    row: int
    col: int


def _cell_index(cell: object, rows: int, cols: int) -> int:
    """The index ``row * cols + col`` of ``cell``, or -1 if it is no ``(row, col)`` pair of
    integers on a ``rows`` x ``cols`` floor (so a view answers "not in" as a set would)."""
    try:
        row, col = cell  # type: ignore[misc]
        row, col = operator.index(row), operator.index(col)
    except (TypeError, ValueError):
        return -1
    return row * cols + col if 0 <= row < rows and 0 <= col < cols else -1


class CellSet(Set):
    """A read-only set of cells over a ``(rows, cols)`` boolean mask, for floors of millions
    of cells: ``(row, col) in cells``, ``len``, iteration yielding :class:`Cell` in row-major
    order, and the set operations and comparisons of :class:`collections.abc.Set` (equal to
    a frozenset of the same cells; ``&``, ``|``, ``-`` give frozensets). :attr:`mask` is
    the array itself."""

    __slots__ = ("_count", "mask")

    def __init__(self, mask: np.ndarray) -> None:
        #: The cells as a read-only ``(rows, cols)`` boolean array.
        self.mask = mask
        self._count = int(np.count_nonzero(mask))

    def __contains__(self, cell: object) -> bool:
        index = _cell_index(cell, *self.mask.shape)
        return index >= 0 and bool(self.mask.flat[index])

    def __len__(self) -> int:
        return self._count

    def __iter__(self) -> Iterator[Cell]:
        for row, line in enumerate(self.mask):  # a row at a time: no list of every cell
            for col in np.flatnonzero(line).tolist():
                yield Cell(row, col)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, CellSet):  # compare the masks, not cell by cell
            return self.mask.shape == other.mask.shape and bool((self.mask == other.mask).all())
        return super().__eq__(other)

    __hash__ = None  # type: ignore[assignment]  # equal to frozensets, so never hashed

    def __repr__(self) -> str:
        shown = list(itertools.islice(self, 8))
        more = f", ... ({self._count:,} cells)" if self._count > len(shown) else ""
        return f"CellSet({shown!r}{more})"

    @classmethod
    def _from_iterable(cls, cells: Iterable[Any]) -> frozenset[Any]:
        return frozenset(cells)  # what & | - ^ give: a plain frozenset


#: Sequences of at most this many cells keep them as a tuple too [cells]: under 1 MB,
#: whatever the floor.
SMALL_SEQUENCE = 4096


class CellSequence(Sequence):
    """A read-only sequence of cells over a sorted array of indices ``row * cols + col``:
    indexing gives :class:`Cell` (a slice, a tuple of them), ``len``, ``in`` and
    :meth:`index` by binary search, iteration, and equality with the tuple of the same
    cells. ``numpy.asarray`` of it is the ``(n, 2)`` int64 array of rows and columns;
    :attr:`indices` the index array itself.

    A sequence of at most :data:`SMALL_SEQUENCE` cells also keeps them as a tuple and
    their positions in a dictionary: a single robot draws its package from one at every
    reset, and a numpy search there cost about a microsecond a reset."""

    __slots__ = ("_positions", "_shape", "_tuple", "indices")

    def __init__(self, indices: np.ndarray, rows: int, cols: int) -> None:
        #: The cells as a read-only, ascending int64 array of indices ``row * cols + col``.
        self.indices = indices
        self._shape = (rows, cols)
        self._tuple: tuple[Cell, ...] | None = None
        self._positions: dict[Cell, int] | None = None
        if len(indices) <= SMALL_SEQUENCE:
            self._tuple = tuple(Cell(*divmod(i, cols)) for i in indices.tolist())
            self._positions = {cell: position for position, cell in enumerate(self._tuple)}

    def __len__(self) -> int:
        return len(self.indices)

    @overload
    def __getitem__(self, position: int) -> Cell: ...
    @overload
    def __getitem__(self, position: slice) -> tuple[Cell, ...]: ...
    def __getitem__(self, position: int | slice) -> Cell | tuple[Cell, ...]:
        if self._tuple is not None:
            return self._tuple[position]
        cols = self._shape[1]
        if isinstance(position, slice):
            return tuple(Cell(*divmod(i, cols)) for i in self.indices[position].tolist())
        return Cell(*divmod(int(self.indices[operator.index(position)]), cols))

    def __iter__(self) -> Iterator[Cell]:
        cols = self._shape[1]
        for begin in range(0, len(self.indices), 1 << 16):  # no list of every cell at once
            for i in self.indices[begin : begin + (1 << 16)].tolist():
                yield Cell(*divmod(i, cols))

    def __contains__(self, cell: object) -> bool:
        return self._position(cell) >= 0

    def index(self, cell: Any, start: int = 0, stop: int | None = None) -> int:
        """The position of ``cell``; ``ValueError`` if it is not one of the cells."""
        position = self._position(cell)
        if position < 0 or not start <= position < (len(self) if stop is None else stop):
            raise ValueError(f"{cell!r} is not in the sequence")
        return position

    def _position(self, cell: object) -> int:
        if (
            self._positions is not None
            and type(cell) in (Cell, tuple)
            and len(cell) == 2  # type: ignore[arg-type]
            and type(cell[0]) is int  # type: ignore[index]
            and type(cell[1]) is int  # type: ignore[index]
        ):  # the hot path: a Cell or a pair of Python ints
            return self._positions.get(cell, -1)  # type: ignore[call-overload]
        index = _cell_index(cell, *self._shape)
        position = int(np.searchsorted(self.indices, index))
        found = index >= 0 and position < len(self.indices) and self.indices[position] == index
        return position if found else -1

    def __eq__(self, other: object) -> bool:
        if isinstance(other, CellSequence):
            return self._shape[1] == other._shape[1] and np.array_equal(self.indices, other.indices)
        if isinstance(other, tuple):  # as the tuple of cells it once was
            return len(other) == len(self) and tuple(self) == other
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> np.ndarray:
        cells = np.stack(np.divmod(self.indices, self._shape[1]), axis=1)
        return cells if dtype is None else cells.astype(dtype)

    def __repr__(self) -> str:
        shown = list(self[:8])
        more = f", ... ({len(self):,} cells)" if len(self) > len(shown) else ""
        return f"CellSequence({shown!r}{more})"


def read_only(values: np.ndarray) -> np.ndarray:
    """``values``, marked read-only: a grid's arrays are shared by every twin."""
    values.flags.writeable = False
    return values
