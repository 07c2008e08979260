"""Cell views: a small sequence's tuple and dictionary answer as the arrays do."""

import numpy as np
import pytest

from warehouse_phys.world import cells as cells_module
from warehouse_phys.world.cells import Cell, CellSequence


@pytest.mark.parametrize("small", [True, False])
def test_small_and_large_sequences_answer_alike(small, monkeypatch):
    if not small:
        monkeypatch.setattr(cells_module, "SMALL_SEQUENCE", 0)
    indices = np.array([1, 5, 6, 11], dtype=np.int64)
    sequence = CellSequence(indices, 3, 4)
    assert (sequence._tuple is not None) == small
    assert sequence[2] == Cell(1, 2)
    assert sequence[-1] == Cell(2, 3)
    assert sequence[1:3] == (Cell(1, 1), Cell(1, 2))
    for cell, position in (((0, 1), 0), (Cell(1, 2), 2), ((np.int64(2), np.int64(3)), 3),
                           ((0, 0), -1), ((1.0, 1.0), -1), ((5, 5), -1), ((-1, 3), -1),
                           ([1, 1], 1), ("ab", -1), ((1, 2, 3), -1)):  # fmt: skip
        assert sequence._position(cell) == position, cell
        assert (cell in sequence) == (position >= 0)
    assert sequence == tuple(sequence)
    with pytest.raises(IndexError):
        sequence[4]
